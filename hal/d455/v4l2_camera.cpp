#include "hal/d455/v4l2_camera.hpp"

#include <fcntl.h>
#include <linux/usb/video.h>
#include <linux/uvcvideo.h>
#include <linux/videodev2.h>
#include <sys/mman.h>

#include <cerrno>
#include <cstring>
#include <stdexcept>

#include "hal/d455/y8i.hpp"

namespace ums::d455 {

namespace {

// Depth extension unit of the D4xx (notes §3.1): unit id 3.
constexpr std::uint8_t kDepthXuUnit = 3;
constexpr std::uint8_t kXuEmitterEnabled = 2;   // u8: 0 off, 1 on, 2 auto
constexpr std::uint8_t kXuExposure = 3;         // u32 µs
constexpr std::uint8_t kXuAutoExposure = 0x0B; // u8: 0/1

std::string fourcc_text(std::uint32_t f) {
  std::string s(4, ' ');
  for (int i = 0; i < 4; ++i) s[static_cast<std::size_t>(i)] = static_cast<char>((f >> (8 * i)) & 0xFF);
  return s;
}

std::string errno_text(int neg_errno) { return std::strerror(-neg_errno); }

}  // namespace

void CameraOptions::validate() const {
  const bool size_ok = (width == 848 || width == 640) && height == 480;
  if (!size_ok) {
    throw std::runtime_error("d455 camera: width x height must be 640x480 or 848x480, got " +
                             std::to_string(width) + "x" + std::to_string(height));
  }
  if (fps != 15 && fps != 30 && fps != 60 && fps != 90) {
    throw std::runtime_error("d455 camera: fps must be 15, 30, 60 or 90, got " + std::to_string(fps));
  }
  if (buffer_count < 2 || buffer_count > capacity::kD455MaxV4l2Buffers) {
    throw std::runtime_error("d455 camera: buffer_count must be in [2, " +
                             std::to_string(capacity::kD455MaxV4l2Buffers) + "], got " +
                             std::to_string(buffer_count));
  }
  if (!auto_exposure && (exposure_us < 1 || exposure_us > 200000)) {
    throw std::runtime_error("d455 camera: exposure_us must be in [1, 200000], got " +
                             std::to_string(exposure_us));
  }
  if (gain != -1 && (gain < 16 || gain > 248)) {
    throw std::runtime_error("d455 camera: gain must be -1 or in [16, 248], got " + std::to_string(gain));
  }
  if (control_retries < 1) throw std::runtime_error("d455 camera: control_retries must be >= 1");
}

V4l2Camera::V4l2Camera(Sys& sys, const CameraOptions& options, DeviceClockMap* clock)
    : sys_(sys), options_(options), clock_(clock) {
  options_.validate();
}

V4l2Camera::~V4l2Camera() { close(); }

Status V4l2Camera::map_buffers(Node* node, int count, std::string* error, const char* what) {
  v4l2_requestbuffers req{};
  req.count = static_cast<std::uint32_t>(count);
  req.type = node->type;
  req.memory = V4L2_MEMORY_MMAP;
  int r = sys_.ioctl(node->fd, VIDIOC_REQBUFS, &req);
  if (r < 0) {
    *error = std::string("d455 ") + what + ": VIDIOC_REQBUFS(" + std::to_string(count) +
             ") failed: " + errno_text(r);
    return r == -ENODEV ? Status::kIoError : Status::kUnsupported;
  }
  if (req.count < 2 || req.count > static_cast<std::uint32_t>(capacity::kD455MaxV4l2Buffers)) {
    *error = std::string("d455 ") + what + ": driver granted " + std::to_string(req.count) +
             " buffers, need 2.." + std::to_string(capacity::kD455MaxV4l2Buffers);
    return Status::kUnsupported;
  }
  node->count = static_cast<int>(req.count);
  for (int i = 0; i < node->count; ++i) {
    v4l2_buffer buf{};
    buf.type = node->type;
    buf.memory = V4L2_MEMORY_MMAP;
    buf.index = static_cast<std::uint32_t>(i);
    r = sys_.ioctl(node->fd, VIDIOC_QUERYBUF, &buf);
    if (r < 0) {
      *error = std::string("d455 ") + what + ": VIDIOC_QUERYBUF " + std::to_string(i) + ": " + errno_text(r);
      return Status::kIoError;
    }
    void* p = sys_.mmap(buf.length, PROT_READ | PROT_WRITE, MAP_SHARED, node->fd,
                        static_cast<off_t>(buf.m.offset));
    if (p == nullptr) {
      *error = std::string("d455 ") + what + ": mmap of buffer " + std::to_string(i) + " failed";
      return Status::kIoError;
    }
    node->ptr[i] = p;
    node->len[i] = buf.length;
  }
  return Status::kOk;
}

void V4l2Camera::unmap(Node* node) {
  for (int i = 0; i < node->count; ++i) {
    if (node->ptr[i] != nullptr) sys_.munmap(node->ptr[i], node->len[i]);
    node->ptr[i] = nullptr;
  }
  if (node->fd >= 0 && node->count > 0) {
    v4l2_requestbuffers req{};
    req.count = 0;
    req.type = node->type;
    req.memory = V4L2_MEMORY_MMAP;
    sys_.ioctl(node->fd, VIDIOC_REQBUFS, &req);
  }
  node->count = 0;
}

Status V4l2Camera::open(const std::string& video_path, const std::string& meta_path, std::string* error) {
  close();
  video_.type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
  video_.fd = sys_.open(video_path.c_str(), O_RDWR | O_NONBLOCK);
  if (video_.fd < 0) {
    *error = "d455: cannot open " + video_path + ": " + errno_text(video_.fd);
    video_.fd = -1;
    return Status::kIoError;
  }
  v4l2_capability cap{};
  int r = sys_.ioctl(video_.fd, VIDIOC_QUERYCAP, &cap);
  const std::uint32_t caps = (cap.capabilities & V4L2_CAP_DEVICE_CAPS) ? cap.device_caps : cap.capabilities;
  if (r < 0 || !(caps & V4L2_CAP_VIDEO_CAPTURE) || !(caps & V4L2_CAP_STREAMING)) {
    *error = "d455: " + video_path + " is not a streaming video capture node";
    close();
    return r == -ENODEV ? Status::kIoError : Status::kUnsupported;
  }
  v4l2_format fmt{};
  fmt.type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
  fmt.fmt.pix.width = static_cast<std::uint32_t>(options_.width);
  fmt.fmt.pix.height = static_cast<std::uint32_t>(options_.height);
  fmt.fmt.pix.pixelformat = V4L2_PIX_FMT_Y8I;
  fmt.fmt.pix.field = V4L2_FIELD_NONE;
  r = sys_.ioctl(video_.fd, VIDIOC_S_FMT, &fmt);
  // Drivers may substitute another format or size instead of failing: check what came back.
  if (r < 0 || fmt.fmt.pix.pixelformat != V4L2_PIX_FMT_Y8I ||
      fmt.fmt.pix.width != static_cast<std::uint32_t>(options_.width) ||
      fmt.fmt.pix.height != static_cast<std::uint32_t>(options_.height)) {
    *error = "d455: " + video_path + " refused Y8I " + std::to_string(options_.width) + "x" +
             std::to_string(options_.height) + (r < 0 ? " (" + errno_text(r) + ")" :
             " (driver answered " + fourcc_text(fmt.fmt.pix.pixelformat) + " " +
             std::to_string(fmt.fmt.pix.width) + "x" + std::to_string(fmt.fmt.pix.height) + ")") +
             "; Y8I needs a USB3 link";
    close();
    return r == -ENODEV ? Status::kIoError : Status::kUnsupported;
  }
  bytesperline_ = fmt.fmt.pix.bytesperline;
  sizeimage_ = fmt.fmt.pix.sizeimage;
  const auto row = static_cast<std::uint32_t>(2 * options_.width);
  if (bytesperline_ < row || sizeimage_ < bytesperline_ * static_cast<std::uint32_t>(options_.height)) {
    *error = "d455: " + video_path + " Y8I layout bytesperline " + std::to_string(bytesperline_) +
             " sizeimage " + std::to_string(sizeimage_) + " too small";
    close();
    return Status::kUnsupported;
  }
  v4l2_streamparm parm{};
  parm.type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
  parm.parm.capture.timeperframe.numerator = 1;
  parm.parm.capture.timeperframe.denominator = static_cast<std::uint32_t>(options_.fps);
  r = sys_.ioctl(video_.fd, VIDIOC_S_PARM, &parm);
  if (r < 0 || parm.parm.capture.timeperframe.numerator == 0 ||
      parm.parm.capture.timeperframe.denominator / parm.parm.capture.timeperframe.numerator !=
          static_cast<std::uint32_t>(options_.fps)) {
    *error = "d455: " + video_path + " refused " + std::to_string(options_.fps) + " fps" +
             (r < 0 ? " (" + errno_text(r) + ")" : "");
    close();
    return r == -ENODEV ? Status::kIoError : Status::kUnsupported;
  }
  Status s = map_buffers(&video_, options_.buffer_count, error, video_path.c_str());
  if (s != Status::kOk) {
    close();
    return s;
  }
  const std::size_t plane = static_cast<std::size_t>(options_.width) * static_cast<std::size_t>(options_.height);
  planes_.reset(new std::uint8_t[4 * plane]());

  if (options_.use_metadata && !meta_path.empty()) {
    meta_.type = V4L2_BUF_TYPE_META_CAPTURE;
    meta_.fd = sys_.open(meta_path.c_str(), O_RDWR | O_NONBLOCK);
    bool ok = meta_.fd >= 0;
    if (ok) {
      // Prefer D4XX (capture timing); uvcvideo silently answers UVCH when the kernel does not enable
      // it for this PID (notes §2.3 step 5), so read back what was set.
      v4l2_format mf{};
      mf.type = V4L2_BUF_TYPE_META_CAPTURE;
      mf.fmt.meta.dataformat = V4L2_META_FMT_D4XX;
      if (sys_.ioctl(meta_.fd, VIDIOC_S_FMT, &mf) < 0) {
        mf = v4l2_format{};
        mf.type = V4L2_BUF_TYPE_META_CAPTURE;
        mf.fmt.meta.dataformat = V4L2_META_FMT_UVC;
        ok = sys_.ioctl(meta_.fd, VIDIOC_S_FMT, &mf) >= 0;
      }
      meta_format_ = ok ? mf.fmt.meta.dataformat : 0;
    }
    std::string meta_error;
    if (ok && map_buffers(&meta_, options_.buffer_count, &meta_error, meta_path.c_str()) != Status::kOk) ok = false;
    if (!ok) {  // frames still have driver timestamps; metadata is an improvement, not a must
      unmap(&meta_);
      if (meta_.fd >= 0) sys_.close(meta_.fd);
      meta_.fd = -1;
      meta_format_ = 0;
    }
  }
  apply_controls(error);
  return Status::kOk;
}

bool V4l2Camera::xu_set(std::uint8_t selector, const void* data, std::uint16_t size) {
  std::uint8_t bytes[4] = {};
  std::memcpy(bytes, data, size);
  for (int attempt = 0; attempt < options_.control_retries; ++attempt) {
    uvc_xu_control_query q{};
    q.unit = kDepthXuUnit;
    q.selector = selector;
    q.query = UVC_SET_CUR;
    q.size = size;
    q.data = bytes;
    if (sys_.ioctl(video_.fd, UVCIOC_CTRL_QUERY, &q) >= 0) return true;
  }
  return false;
}

void V4l2Camera::apply_controls(std::string* error) {
  std::string failed;
  if (options_.emitter_off) {
    const std::uint8_t off = 0;
    if (!xu_set(kXuEmitterEnabled, &off, 1)) failed += " emitter";
  }
  const std::uint8_t ae = options_.auto_exposure ? 1 : 0;
  if (!xu_set(kXuAutoExposure, &ae, 1)) failed += " auto_exposure";
  if (!options_.auto_exposure) {
    const auto exposure = static_cast<std::uint32_t>(options_.exposure_us);
    if (!xu_set(kXuExposure, &exposure, 4)) failed += " exposure";
  }
  if (options_.gain >= 0) {
    v4l2_control ctrl{};
    ctrl.id = V4L2_CID_GAIN;
    ctrl.value = options_.gain;
    if (sys_.ioctl(video_.fd, VIDIOC_S_CTRL, &ctrl) < 0) failed += " gain";
  }
  if (!failed.empty()) {
    for (char c : failed) stats_.control_failures += (c == ' ') ? 1 : 0;
    *error = "d455: controls refused by the device:" + failed;
  }
}

Status V4l2Camera::queue_all(Node* node) {
  for (int i = 0; i < node->count; ++i) {
    const Status s = requeue(node, static_cast<std::uint32_t>(i));
    if (s != Status::kOk) return s;
  }
  return Status::kOk;
}

Status V4l2Camera::requeue(Node* node, std::uint32_t index) {
  v4l2_buffer buf{};
  buf.type = node->type;
  buf.memory = V4L2_MEMORY_MMAP;
  buf.index = index;
  const int r = sys_.ioctl(node->fd, VIDIOC_QBUF, &buf);
  if (r == -ENODEV) disconnected_ = true;
  return r < 0 ? Status::kIoError : Status::kOk;
}

Status V4l2Camera::start(std::string* error) {
  if (video_.fd < 0) {
    *error = "d455: start() before open()";
    return Status::kIoError;
  }
  for (auto& m : pending_meta_) m.used = true;
  if (meta_.fd >= 0) {
    int type = static_cast<int>(meta_.type);
    if (queue_all(&meta_) != Status::kOk || sys_.ioctl(meta_.fd, VIDIOC_STREAMON, &type) < 0) {
      *error = "d455: metadata STREAMON failed";
      return Status::kIoError;
    }
  }
  int type = static_cast<int>(video_.type);
  int r = 0;
  if (queue_all(&video_) != Status::kOk || (r = sys_.ioctl(video_.fd, VIDIOC_STREAMON, &type)) < 0) {
    *error = "d455: video STREAMON failed" + (r < 0 ? ": " + errno_text(r) : std::string());
    return Status::kIoError;
  }
  streaming_ = true;
  have_sequence_ = false;  // sequence restarts at 0 after STREAMON
  return Status::kOk;
}

void V4l2Camera::stop() {
  if (!streaming_) return;
  int type = static_cast<int>(video_.type);
  sys_.ioctl(video_.fd, VIDIOC_STREAMOFF, &type);
  if (meta_.fd >= 0) {
    type = static_cast<int>(meta_.type);
    sys_.ioctl(meta_.fd, VIDIOC_STREAMOFF, &type);
  }
  streaming_ = false;
}

Status V4l2Camera::restart(std::string* error) {
  stop();
  return start(error);
}

void V4l2Camera::close() {
  stop();
  unmap(&meta_);
  unmap(&video_);
  if (meta_.fd >= 0) sys_.close(meta_.fd);
  if (video_.fd >= 0) sys_.close(video_.fd);
  meta_.fd = -1;
  video_.fd = -1;
}

int V4l2Camera::poll_fds(pollfd* fds, int max) const {
  int n = 0;
  if (video_.fd >= 0 && n < max) fds[n++] = pollfd{video_.fd, POLLIN, 0};
  if (meta_.fd >= 0 && n < max) fds[n++] = pollfd{meta_.fd, POLLIN, 0};
  return n;
}

void V4l2Camera::drain_meta() {
  if (meta_.fd < 0) return;
  for (;;) {
    v4l2_buffer buf{};
    buf.type = meta_.type;
    buf.memory = V4L2_MEMORY_MMAP;
    const int r = sys_.ioctl(meta_.fd, VIDIOC_DQBUF, &buf);
    if (r < 0) {
      if (r == -ENODEV) disconnected_ = true;
      return;
    }
    UvcFrameMeta meta;
    const bool ok = buf.index < static_cast<std::uint32_t>(meta_.count) &&
                    parse_uvc_metadata(static_cast<const std::uint8_t*>(meta_.ptr[buf.index]),
                                       buf.bytesused, &meta);
    if (ok) {
      // Replace the oldest used (or any used) slot; an unused one being overwritten is a lost match.
      MetaEntry* slot = nullptr;
      for (auto& e : pending_meta_) {
        if (e.used) {
          slot = &e;
          break;
        }
      }
      if (slot == nullptr) {
        slot = &pending_meta_[0];
        for (auto& e : pending_meta_) {
          if (e.sequence < slot->sequence) slot = &e;
        }
        ++stats_.meta_unmatched;
      }
      slot->sequence = buf.sequence;  // uvcvideo copies the video buffer's sequence (notes §2.3)
      slot->meta = meta;
      slot->used = false;
    } else {
      ++stats_.meta_unmatched;
    }
    if (buf.index < static_cast<std::uint32_t>(meta_.count)) requeue(&meta_, buf.index);
  }
}

Status V4l2Camera::try_dequeue(StereoFrame* frame, FrameInfo* info) {
  if (disconnected_) return Status::kIoError;
  if (!streaming_) return Status::kEmpty;
  drain_meta();
  for (;;) {
    v4l2_buffer buf{};
    buf.type = video_.type;
    buf.memory = V4L2_MEMORY_MMAP;
    const int r = sys_.ioctl(video_.fd, VIDIOC_DQBUF, &buf);
    if (r == -EAGAIN) return Status::kEmpty;
    if (r < 0) {
      if (r == -ENODEV || r == -EIO || r == -EPIPE) disconnected_ = true;
      return Status::kIoError;
    }
    if (buf.index >= static_cast<std::uint32_t>(video_.count)) return Status::kIoError;
    if (have_sequence_ && static_cast<std::int32_t>(buf.sequence - last_sequence_) <= 0) {
      ++stats_.out_of_order;
      if (requeue(&video_, buf.index) != Status::kOk) return Status::kIoError;
      continue;
    }
    if (have_sequence_) stats_.sequence_gaps += buf.sequence - last_sequence_ - 1;
    have_sequence_ = true;
    last_sequence_ = buf.sequence;
    if ((buf.flags & V4L2_BUF_FLAG_ERROR) || buf.bytesused != sizeimage_) {
      ++stats_.bad_frames;  // uvcvideo marks incomplete frames (notes §2.3); never pass them on
      if (requeue(&video_, buf.index) != Status::kOk) return Status::kIoError;
      continue;
    }

    FrameInfo fi;
    fi.v4l2_sequence = buf.sequence;
    fi.driver_ns = static_cast<std::int64_t>(buf.timestamp.tv_sec) * 1000000000LL +
                   static_cast<std::int64_t>(buf.timestamp.tv_usec) * 1000LL;
    std::int64_t t_ns = fi.driver_ns;
    for (auto& e : pending_meta_) {
      if (e.used || e.sequence != buf.sequence) continue;
      e.used = true;
      if (e.meta.has_emitter_mode) fi.emitter_mode = e.meta.emitter_mode;
      fi.exposure_us = e.meta.exposure_us;
      if (e.meta.has_pts && clock_ != nullptr) {
        const std::int64_t pts_us = clock_->unwrap_us(e.meta.pts_us);
        // The driver stamps the first payload's arrival, which follows readout start (PTS).
        clock_->observe(pts_us * 1000, fi.driver_ns);
        fi.has_device_time = true;
        fi.device_mid_exposure_us =
            e.meta.has_capture_timing ? pts_us - static_cast<std::int64_t>(e.meta.sensor_offset_us) : pts_us;
        if (options_.use_device_timestamps) t_ns = clock_->to_host_ns(fi.device_mid_exposure_us * 1000);
      }
    }
    const bool duplicate = gate_.started() && t_ns == gate_.last_ns();
    if (!gate_.accept(t_ns)) {
      ++(duplicate ? stats_.duplicates : stats_.out_of_order);
      if (requeue(&video_, buf.index) != Status::kOk) return Status::kIoError;
      continue;
    }
    const std::size_t plane = static_cast<std::size_t>(options_.width) * static_cast<std::size_t>(options_.height);
    std::uint8_t* left = planes_.get() + static_cast<std::size_t>(2 * slot_) * plane;
    std::uint8_t* right = left + plane;
    deinterleave_y8i(static_cast<const std::uint8_t*>(video_.ptr[buf.index]), options_.width,
                     options_.height, static_cast<int>(bytesperline_), left, options_.width, right,
                     options_.width);
    slot_ ^= 1;
    // The pixels are copied out: the buffer goes straight back to the driver.
    if (requeue(&video_, buf.index) != Status::kOk) return Status::kIoError;
    frame->t_ns = t_ns;
    frame->seq = delivered_++;
    frame->left = ImageView{left, options_.width, options_.height, options_.width};
    frame->right = ImageView{right, options_.width, options_.height, options_.width};
    if (info != nullptr) *info = fi;
    ++stats_.frames;
    return Status::kOk;
  }
}

Status V4l2Camera::next(StereoFrame* frame, FrameInfo* info, int timeout_ms) {
  const std::int64_t deadline = monotonic_now_ns() + static_cast<std::int64_t>(timeout_ms) * 1000000LL;
  for (;;) {
    Status s = try_dequeue(frame, info);
    if (s != Status::kEmpty) return s;
    const std::int64_t left_ns = deadline - monotonic_now_ns();
    pollfd fds[2];
    const int n = poll_fds(fds, 2);
    const int r = left_ns > 0 ? sys_.poll(fds, static_cast<nfds_t>(n), static_cast<int>(left_ns / 1000000)) : 0;
    if (r < 0) return Status::kIoError;
    if (r == 0) {
      ++stats_.timeouts;
      return Status::kTimeout;
    }
    if (fds[0].revents & (POLLERR | POLLHUP | POLLNVAL)) {
      // uvcvideo reports POLLERR on an unplugged device; confirm through DQBUF's errno.
      s = try_dequeue(frame, info);
      if (s == Status::kEmpty) {
        disconnected_ = true;
        return Status::kIoError;
      }
      return s;
    }
  }
}

}  // namespace ums::d455
