#include "tests/hal/d455/fake_kernel.hpp"

#include <linux/usb/video.h>
#include <linux/uvcvideo.h>
#include <linux/videodev2.h>
#include <time.h>

#include <cerrno>
#include <cstring>
#include <filesystem>
#include <fstream>

namespace ums::d455::test {

namespace {
constexpr off_t kOffsetStride = 0x100000;

template <typename T>
void put(std::vector<std::uint8_t>* b, std::size_t at, T v) {
  if (b->size() < at + sizeof(T)) b->resize(at + sizeof(T));
  std::memcpy(b->data() + at, &v, sizeof(T));
}
}  // namespace

FakeKernel::FakeKernel() = default;

FakeKernel::Video& FakeKernel::add_video(const std::string& path, std::vector<std::uint32_t> formats) {
  Video& v = videos_[path];
  v.path = path;
  v.formats = std::move(formats);
  return v;
}

FakeKernel::Video& FakeKernel::add_meta(const std::string& path, bool d4xx) {
  Video& v = videos_[path];
  v.path = path;
  v.meta = true;
  v.formats = d4xx ? std::vector<std::uint32_t>{V4L2_META_FMT_D4XX, V4L2_META_FMT_UVC}
                   : std::vector<std::uint32_t>{V4L2_META_FMT_UVC};
  return v;
}

void FakeKernel::add_iio(const std::string& path) { iio_[path]; }

void FakeKernel::push_iio(const std::string& path, const std::vector<std::uint8_t>& bytes) {
  iio_[path].push_back(bytes);
}

FakeKernel::Video* FakeKernel::video(const std::string& path) {
  auto it = videos_.find(path);
  return it == videos_.end() ? nullptr : &it->second;
}

bool FakeKernel::produce_frame(const std::string& video_path, int seed, const FakeFrameSpec& spec) {
  Video& v = videos_.at(video_path);
  if (!v.streaming) return false;
  const std::uint32_t seq = spec.sequence_override >= 0 ? static_cast<std::uint32_t>(spec.sequence_override) : v.sequence;
  v.sequence = seq + 1;
  if (v.queued.empty()) {
    ++v.dropped_no_buffer;
    return false;
  }
  const int index = v.queued.front();
  v.queued.erase(v.queued.begin());
  std::vector<std::uint8_t>& buf = v.buffers[static_cast<std::size_t>(index)];
  for (std::uint32_t y = 0; y < v.height; ++y) {
    for (std::uint32_t x = 0; x < v.width; ++x) {
      buf[y * v.bytesperline + 2 * x] = left_pixel(static_cast<int>(x), static_cast<int>(y), seed);
      buf[y * v.bytesperline + 2 * x + 1] = right_pixel(static_cast<int>(x), static_cast<int>(y), seed);
    }
  }
  std::uint32_t flags = spec.error_flag ? V4L2_BUF_FLAG_ERROR : 0;
  v.done.push_back({index, v.sizeimage - static_cast<std::uint32_t>(spec.bytes_short), flags, seq, spec.driver_ns});

  // The metadata node (registered as the next node number by convention: path + "m" not needed;
  // find the streaming meta node).
  if (!spec.with_meta) return true;
  for (auto& [path, m] : videos_) {
    if (!m.meta || !m.streaming || m.queued.empty()) continue;
    const int mi = m.queued.front();
    m.queued.erase(m.queued.begin());
    std::vector<std::uint8_t> b;
    put<std::uint64_t>(&b, 0, static_cast<std::uint64_t>(spec.driver_ns));
    put<std::uint16_t>(&b, 8, 1234);
    const bool d4xx = m.meta_format == V4L2_META_FMT_D4XX;
    const std::uint8_t header_len = d4xx ? 12 + 40 + 60 : 12;
    put<std::uint8_t>(&b, 10, header_len);
    put<std::uint8_t>(&b, 11, 0x0C | 0x02);  // PTS, SCR, EOF
    put<std::uint32_t>(&b, 12, spec.pts_us);
    put<std::uint32_t>(&b, 16, spec.pts_us - 100);  // STC
    put<std::uint16_t>(&b, 20, 77);                  // SOF
    if (d4xx) {
      const std::size_t ct = 22;
      put<std::uint32_t>(&b, ct, 0x80000001u);
      put<std::uint32_t>(&b, ct + 4, 40);
      put<std::uint32_t>(&b, ct + 8, 1);
      put<std::uint32_t>(&b, ct + 12, 0x0Bu);  // frame_counter, sensor_timestamp, exposure
      put<std::uint32_t>(&b, ct + 16, spec.frame_counter);
      put<std::uint32_t>(&b, ct + 20, spec.sensor_offset_us);
      put<std::uint32_t>(&b, ct + 28, 8000);
      put<std::uint32_t>(&b, ct + 36, 0);
      const std::size_t dc = ct + 40;
      put<std::uint32_t>(&b, dc, 0x80000000u);
      put<std::uint32_t>(&b, dc + 4, 60);
      put<std::uint8_t>(&b, dc + 56, spec.emitter_mode);
      put<std::uint8_t>(&b, dc + 59, 0);
    }
    std::vector<std::uint8_t>& mb = m.buffers[static_cast<std::size_t>(mi)];
    std::memcpy(mb.data(), b.data(), std::min(b.size(), mb.size()));
    m.done.push_back({mi, static_cast<std::uint32_t>(b.size()), 0, seq, spec.driver_ns});
    break;
  }
  return true;
}

int FakeKernel::open(const char* path, int) {
  if (unplugged_) return -ENODEV;
  const std::string p(path);
  if (videos_.count(p) == 0 && iio_.count(p) == 0) return -ENOENT;
  const int fd = next_fd_++;
  fds_[fd] = p;
  return fd;
}

int FakeKernel::close(int fd) { return fds_.erase(fd) == 1 ? 0 : -EBADF; }

void* FakeKernel::mmap(std::size_t length, int, int, int fd, off_t offset) {
  auto it = fds_.find(fd);
  if (it == fds_.end() || unplugged_) return nullptr;
  Video* v = video(it->second);
  if (v == nullptr) return nullptr;
  const auto index = static_cast<std::size_t>(offset / kOffsetStride);
  if (index >= v->buffers.size() || length > v->buffers[index].size()) return nullptr;
  ++mapped_;
  return v->buffers[index].data();
}

int FakeKernel::munmap(void*, std::size_t) {
  --mapped_;
  return 0;
}

int FakeKernel::poll(pollfd* fds, nfds_t nfds, int timeout_ms) {
  ++polls_;
  if (on_poll) on_poll(polls_);
  int ready = 0;
  for (nfds_t i = 0; i < nfds; ++i) {
    fds[i].revents = 0;
    auto it = fds_.find(fds[i].fd);
    if (it == fds_.end()) {
      fds[i].revents = POLLNVAL;
    } else if (unplugged_) {
      fds[i].revents = POLLERR | POLLHUP;
    } else if (Video* v = video(it->second)) {
      if (!v->done.empty()) fds[i].revents = POLLIN;
    } else if (!iio_[it->second].empty()) {
      fds[i].revents = POLLIN;
    }
    if (fds[i].revents != 0) ++ready;
  }
  if (ready == 0 && sleep_on_timeout && timeout_ms > 0) {
    timespec ts{timeout_ms / 1000, static_cast<long>(timeout_ms % 1000) * 1000000L};
    nanosleep(&ts, nullptr);
  }
  return ready;
}

ssize_t FakeKernel::read(int fd, void* buf, std::size_t count) {
  auto it = fds_.find(fd);
  if (it == fds_.end()) return -EBADF;
  if (unplugged_) return -ENODEV;
  auto q = iio_.find(it->second);
  if (q == iio_.end()) return -EINVAL;
  if (q->second.empty()) return -EAGAIN;
  // Like the kernel FIFO: as many whole pushes as fit, or the front push cut to the read size.
  auto* dst = static_cast<std::uint8_t*>(buf);
  std::size_t total = 0;
  while (!q->second.empty()) {
    std::vector<std::uint8_t>& chunk = q->second.front();
    if (total > 0 && chunk.size() > count - total) break;
    const std::size_t n = std::min(count - total, chunk.size());
    std::memcpy(dst + total, chunk.data(), n);
    total += n;
    chunk.erase(chunk.begin(), chunk.begin() + static_cast<long>(n));
    if (!chunk.empty()) break;
    q->second.pop_front();
  }
  return static_cast<ssize_t>(total);
}

int FakeKernel::ioctl(int fd, unsigned long request, void* arg) {
  auto it = fds_.find(fd);
  if (it == fds_.end()) return -EBADF;
  if (unplugged_) return -ENODEV;
  Video* v = video(it->second);
  if (v == nullptr) return -ENOTTY;
  return video_ioctl(*v, request, arg);
}

int FakeKernel::video_ioctl(Video& v, unsigned long request, void* arg) {
  switch (request) {
    case VIDIOC_QUERYCAP: {
      auto* cap = static_cast<v4l2_capability*>(arg);
      *cap = v4l2_capability{};
      std::strncpy(reinterpret_cast<char*>(cap->driver), "uvcvideo", sizeof cap->driver - 1);
      cap->device_caps = (v.meta ? V4L2_CAP_META_CAPTURE : V4L2_CAP_VIDEO_CAPTURE) | V4L2_CAP_STREAMING;
      cap->capabilities = cap->device_caps | V4L2_CAP_DEVICE_CAPS | V4L2_CAP_VIDEO_CAPTURE | V4L2_CAP_META_CAPTURE;
      return 0;
    }
    case VIDIOC_ENUM_FMT: {
      auto* d = static_cast<v4l2_fmtdesc*>(arg);
      if (d->index >= v.formats.size() || v.meta) return -EINVAL;
      d->pixelformat = v.formats[d->index];
      return 0;
    }
    case VIDIOC_S_FMT: {
      auto* f = static_cast<v4l2_format*>(arg);
      if (v.streaming || !v.buffers.empty()) return -EBUSY;
      if (v.meta) {
        if (f->type != V4L2_BUF_TYPE_META_CAPTURE) return -EINVAL;
        // uvcvideo substitutes UVCH when the device is not enabled for D4XX.
        bool found = false;
        for (auto fmt : v.formats) found = found || fmt == f->fmt.meta.dataformat;
        if (!found) f->fmt.meta.dataformat = V4L2_META_FMT_UVC;
        f->fmt.meta.buffersize = 10 + 255;
        v.meta_format = f->fmt.meta.dataformat;
        return 0;
      }
      if (f->type != V4L2_BUF_TYPE_VIDEO_CAPTURE) return -EINVAL;
      bool found = false;
      for (auto fmt : v.formats) found = found || fmt == f->fmt.pix.pixelformat;
      if (!found || v.substitute_format) f->fmt.pix.pixelformat = v.formats.empty() ? 0 : v.formats[0];
      if (v.substitute_format) f->fmt.pix.pixelformat = V4L2_PIX_FMT_YUYV;
      if (f->fmt.pix.width != 640 && f->fmt.pix.width != 848) f->fmt.pix.width = 848;
      f->fmt.pix.height = 480;
      f->fmt.pix.bytesperline = 2 * f->fmt.pix.width;
      f->fmt.pix.sizeimage = f->fmt.pix.bytesperline * f->fmt.pix.height;
      v.pixelformat = f->fmt.pix.pixelformat;
      v.width = f->fmt.pix.width;
      v.height = f->fmt.pix.height;
      v.bytesperline = f->fmt.pix.bytesperline;
      v.sizeimage = f->fmt.pix.sizeimage;
      return 0;
    }
    case VIDIOC_S_PARM: {
      auto* p = static_cast<v4l2_streamparm*>(arg);
      const auto& tpf = p->parm.capture.timeperframe;
      int want = tpf.numerator == 0 ? 30 : static_cast<int>(tpf.denominator / tpf.numerator);
      int best = v.fps.front();
      for (int f : v.fps) {
        if (std::abs(f - want) < std::abs(best - want)) best = f;
      }
      p->parm.capture.timeperframe.numerator = 1;
      p->parm.capture.timeperframe.denominator = static_cast<std::uint32_t>(best);
      v.fps_set = best;
      return 0;
    }
    case VIDIOC_REQBUFS: {
      auto* r = static_cast<v4l2_requestbuffers*>(arg);
      if (v.streaming) return -EBUSY;
      v.buffers.clear();
      v.queued.clear();
      v.done.clear();
      v.queued.reserve(64);
      v.done.reserve(64);
      const std::uint32_t n = std::min<std::uint32_t>(r->count, static_cast<std::uint32_t>(v.max_buffers));
      const std::size_t size = v.meta ? 10 + 255 : v.sizeimage;
      for (std::uint32_t i = 0; i < n; ++i) v.buffers.emplace_back(size, 0);
      r->count = n;
      return 0;
    }
    case VIDIOC_QUERYBUF: {
      auto* b = static_cast<v4l2_buffer*>(arg);
      if (b->index >= v.buffers.size()) return -EINVAL;
      b->length = static_cast<std::uint32_t>(v.buffers[b->index].size());
      b->m.offset = static_cast<std::uint32_t>(b->index * kOffsetStride);
      return 0;
    }
    case VIDIOC_QBUF: {
      auto* b = static_cast<v4l2_buffer*>(arg);
      if (b->index >= v.buffers.size()) return -EINVAL;
      for (int q : v.queued) {
        if (q == static_cast<int>(b->index)) return -EINVAL;  // already queued
      }
      v.queued.push_back(static_cast<int>(b->index));
      return 0;
    }
    case VIDIOC_DQBUF: {
      auto* b = static_cast<v4l2_buffer*>(arg);
      if (v.done.empty()) return -EAGAIN;
      const Video::Done d = v.done.front();
      v.done.erase(v.done.begin());
      b->index = static_cast<std::uint32_t>(d.index);
      b->bytesused = d.bytesused;
      b->flags = d.flags | V4L2_BUF_FLAG_TIMESTAMP_MONOTONIC;
      b->sequence = d.sequence;
      b->timestamp.tv_sec = static_cast<time_t>(d.t_ns / 1000000000LL);
      b->timestamp.tv_usec = static_cast<suseconds_t>((d.t_ns % 1000000000LL) / 1000);
      return 0;
    }
    case VIDIOC_STREAMON:
      if (v.buffers.empty()) return -EINVAL;
      v.streaming = true;
      v.sequence = 0;
      ++v.streamon_count;
      return 0;
    case VIDIOC_STREAMOFF:
      // vb2 returns every buffer to user space on STREAMOFF.
      v.streaming = false;
      v.queued.clear();
      v.done.clear();
      return 0;
    case VIDIOC_S_CTRL: {
      auto* c = static_cast<v4l2_control*>(arg);
      ctrl_writes[c->id] = c->value;
      return 0;
    }
    case UVCIOC_CTRL_QUERY: {
      auto* q = static_cast<uvc_xu_control_query*>(arg);
      if (refuse_xu) return -EIO;
      if (q->unit != 3) return -EINVAL;
      if (q->query == UVC_GET_CUR && q->selector == 1) {
        if (hwm_reply.size() != q->size) return -EIO;
        std::memcpy(q->data, hwm_reply.data(), q->size);
        return 0;
      }
      if (q->query != UVC_SET_CUR) return -EINVAL;
      xu_writes[q->selector] = std::vector<std::uint8_t>(q->data, q->data + q->size);
      if (q->selector == 1) hwm_request = xu_writes[q->selector];
      return 0;
    }
    default:
      return -ENOTTY;
  }
}

namespace {
void write_file(const std::filesystem::path& p, const std::string& text) {
  std::filesystem::create_directories(p.parent_path());
  std::ofstream(p) << text << "\n";
}

void make_iio(const std::filesystem::path& dir, const std::string& name, const std::string& prefix, int realbits) {
  std::filesystem::create_directories(dir);
  write_file(dir / "name", name);
  write_file(dir / "buffer/enable", "1");  // enabled at plug time (notes §7.10)
  write_file(dir / "buffer/length", "2");
  write_file(dir / "trigger/current_trigger", "");
  write_file(dir / ("in_" + prefix + "_sampling_frequency"), "0");
  write_file(dir / ("in_" + prefix + "_hysteresis"), "0");
  write_file(dir / ("in_" + prefix + "_scale"), "0.009806650");
  write_file(dir / "current_timestamp_clock", "realtime");
  const char* axes[3] = {"x", "y", "z"};
  const std::string type = "le:s" + std::to_string(realbits) + "/32>>0";
  for (int a = 0; a < 3; ++a) {
    const std::string c = "scan_elements/in_" + prefix + "_" + axes[a];
    write_file(dir / (c + "_en"), "0");
    write_file(dir / (c + "_type"), type);
    write_file(dir / (c + "_index"), std::to_string(a));
  }
  write_file(dir / "scan_elements/in_timestamp_en", "0");
  write_file(dir / "scan_elements/in_timestamp_type", "le:s64/64>>0");
  write_file(dir / "scan_elements/in_timestamp_index", "3");
}
}  // namespace

void build_d455_tree(const std::string& root_text, FakeKernel* kernel, int realbits) {
  namespace fs = std::filesystem;
  const fs::path root(root_text);
  const fs::path usb = root / "sys/devices/pci0000:00/0000:00:14.0/usb2/2-1";
  write_file(usb / "idVendor", "8086");
  write_file(usb / "idProduct", "0b5c");
  write_file(usb / "speed", "5000");
  fs::create_directories(root / "sys/class/video4linux");
  fs::create_directories(root / "sys/bus/iio/devices");
  fs::create_directories(root / "dev");
  auto add_interface = [&](const fs::path& dev, int mi, const std::string& modalias) {
    const fs::path itf = dev / (dev.filename().string() + ":1." + std::to_string(mi));
    write_file(itf / "modalias", modalias);
    char mi_text[8];
    std::snprintf(mi_text, sizeof mi_text, "%02x", mi);
    write_file(itf / "bInterfaceNumber", mi_text);
    return itf;
  };
  auto add_node = [&](const fs::path& itf, int n) {
    const std::string name = "video" + std::to_string(n);
    const fs::path node = itf / "video4linux" / name;
    fs::create_directories(node);
    write_file(node / "name", "Intel(R) RealSense(TM) Depth Ca");
    fs::create_directory_symlink("../..", node / "device");
    fs::create_directory_symlink(node, root / "sys/class/video4linux" / name);
  };
  const std::string d455_alias = "usb:v8086p0B5Cd5013dcEFdsc02dp01ic0Eisc01ip00in00";
  const fs::path if0 = add_interface(usb, 0, d455_alias);
  for (int n = 0; n < 4; ++n) add_node(if0, n);
  const fs::path if3 = add_interface(usb, 3, "usb:v8086p0B5Cd5013dcEFdsc02dp01ic0Eisc01ip00in03");
  add_node(if3, 4);
  add_node(if3, 5);
  const fs::path hid = usb / "2-1:1.5/0003:8086:0B5C.0001";
  const fs::path accel = hid / "HID-SENSOR-200073.0.auto/iio:device0";
  const fs::path gyro = hid / "HID-SENSOR-200076.1.auto/iio:device1";
  make_iio(accel, "accel_3d", "accel", realbits);
  make_iio(gyro, "gyro_3d", "anglvel", realbits);
  fs::create_directory_symlink(accel, root / "sys/bus/iio/devices/iio:device0");
  fs::create_directory_symlink(gyro, root / "sys/bus/iio/devices/iio:device1");
  // An unrelated webcam and an unrelated (laptop) accelerometer.
  const fs::path cam = root / "sys/devices/pci0000:00/0000:00:14.0/usb1/1-4";
  write_file(cam / "idVendor", "046d");
  const fs::path camif = add_interface(cam, 0, "usb:v046Dp0825d0012dcEFdsc02dp01ic0Eisc01ip00in00");
  add_node(camif, 6);
  const fs::path other = root / "sys/devices/platform/HID-SENSOR-200073.9.auto/iio:device2";
  make_iio(other, "accel_3d", "accel", 16);
  fs::create_directory_symlink(other, root / "sys/bus/iio/devices/iio:device2");

  const std::string d = root_text + "/dev/";
  kernel->add_video(d + "video0", {v4l2_fourcc('Z', '1', '6', ' ')});
  kernel->add_meta(d + "video1");
  kernel->add_video(d + "video2", {V4L2_PIX_FMT_GREY, V4L2_PIX_FMT_Y8I, v4l2_fourcc('Y', '1', '2', 'I'), V4L2_PIX_FMT_UYVY});
  kernel->add_meta(d + "video3");
  kernel->add_video(d + "video4", {V4L2_PIX_FMT_YUYV});
  kernel->add_meta(d + "video5");
  kernel->add_video(d + "video6", {V4L2_PIX_FMT_YUYV, V4L2_PIX_FMT_MJPEG});
  kernel->add_iio(d + "iio:device0");
  kernel->add_iio(d + "iio:device1");
  kernel->add_iio(d + "iio:device2");
}

std::vector<std::uint8_t> iio_record(std::int32_t x, std::int32_t y, std::int32_t z, std::int64_t ts) {
  std::vector<std::uint8_t> r(24, 0);
  std::memcpy(r.data() + 0, &x, 4);
  std::memcpy(r.data() + 4, &y, 4);
  std::memcpy(r.data() + 8, &z, 4);
  std::memcpy(r.data() + 16, &ts, 8);
  return r;
}

}  // namespace ums::d455::test
