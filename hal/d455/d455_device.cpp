#include "hal/d455/d455_device.hpp"

#include <stdexcept>

namespace ums::d455 {

void D455Options::validate() const {
  camera.validate();
  imu.validate();
  clock.validate();
  if (max_frame_hold_ms < 0 || max_frame_hold_ms > 10000) {
    throw std::runtime_error("d455: max_frame_hold_ms must be in [0, 10000], got " +
                             std::to_string(max_frame_hold_ms));
  }
}

D455Device::D455Device(Sys& sys, const SysFs& fs, const D455Options& options)
    : sys_(sys), fs_(fs), options_(options), clock_(options.clock) {
  options_.validate();
}

D455Device::~D455Device() { stop(); }

Status D455Device::open(std::string* error) {
  D455Nodes nodes;
  if (!find_d455(fs_, sys_, &nodes, error)) return Status::kIoError;
  return open_nodes(nodes, error);
}

Status D455Device::open_nodes(const D455Nodes& nodes, std::string* error) {
  nodes_ = nodes;
  camera_ = std::make_unique<V4l2Camera>(sys_, options_.camera, &clock_);
  const std::string meta = nodes.meta_path.empty() ? std::string() : fs_.host_path(nodes.meta_path);
  std::string control_note;
  Status s = camera_->open(fs_.host_path(nodes.video_path), meta, &control_note);
  if (s != Status::kOk) {
    *error = control_note;
    return s;
  }
  if (!control_note.empty()) *error = control_note;  // controls refused: a warning, not fatal
  accel_.reset();
  gyro_.reset();
  if (nodes.accel_sysfs.empty() || nodes.gyro_sysfs.empty()) {
    if (options_.require_imu) {
      *error = "d455: no accel_3d/gyro_3d IIO devices under " + nodes.usb_device +
               " (kernel needs CONFIG_HID_SENSOR_ACCEL_3D/GYRO_3D, docs/hal-d455.md)";
      return Status::kUnsupported;
    }
    return Status::kOk;
  }
  accel_ = std::make_unique<IioSensor>(sys_, fs_, ImuKind::kAccel, options_.imu, &clock_);
  gyro_ = std::make_unique<IioSensor>(sys_, fs_, ImuKind::kGyro, options_.imu, &clock_);
  s = accel_->open(nodes.accel_sysfs, nodes.accel_dev, error);
  if (s == Status::kOk) s = gyro_->open(nodes.gyro_sysfs, nodes.gyro_dev, error);
  if (s != Status::kOk) {
    accel_.reset();
    gyro_.reset();
  }
  return s;
}

Status D455Device::start(std::string* error) {
  if (camera_ == nullptr) {
    *error = "d455: start() before open()";
    return Status::kIoError;
  }
  // stop() closed the IIO devices (their buffers power the HID sensors): reopen for a new session.
  if (accel_ != nullptr && accel_->fd() < 0) {
    const Status s = accel_->open(nodes_.accel_sysfs, nodes_.accel_dev, error);
    if (s != Status::kOk) return s;
  }
  if (gyro_ != nullptr && gyro_->fd() < 0) {
    const Status s = gyro_->open(nodes_.gyro_sysfs, nodes_.gyro_dev, error);
    if (s != Status::kOk) return s;
  }
  return camera_->start(error);
}

void D455Device::stop() {
  if (camera_ != nullptr) camera_->stop();
  if (accel_ != nullptr) accel_->close();
  if (gyro_ != nullptr) gyro_->close();
}

void D455Device::release_frame(MeasurementSink& sink) {
  if (!has_pending_) return;
  sink.on_stereo(pending_);
  last_frame_t_ns_ = pending_.t_ns;
  has_pending_ = false;
  ++counters_.frames;
}

void D455Device::deliver(MeasurementSink& sink, std::int64_t now_ns) {
  ImuSample s;
  while (fuser_.pop(&s) == Status::kOk) {
    if (s.t_ns < last_frame_t_ns_) ++counters_.imu_behind_frame;
    sink.on_imu(s);
    last_imu_t_ns_ = s.t_ns;
    ++counters_.imu_samples;
    // The first sample at or after the frame's stamp lets the consumer interpolate up to it.
    if (has_pending_ && s.t_ns >= pending_.t_ns) release_frame(sink);
  }
  if (!has_pending_) return;
  // The IMU usually runs ahead of frames (frames carry more latency): a frame whose stamp the
  // delivered IMU has already passed goes at once.
  if (accel_ == nullptr || last_imu_t_ns_ >= pending_.t_ns) {
    release_frame(sink);
  } else if (now_ns - pending_since_ns_ >= static_cast<std::int64_t>(options_.max_frame_hold_ms) * 1000000LL) {
    ++counters_.frames_released_without_imu;
    release_frame(sink);
  }
}

void D455Device::flush(MeasurementSink& sink) {
  deliver(sink, monotonic_now_ns());
  release_frame(sink);
}

Status D455Device::poll_once(MeasurementSink& sink, int timeout_ms) {
  if (camera_ == nullptr) return Status::kIoError;
  pollfd fds[4];
  int n = camera_->poll_fds(fds, 2);
  const int imu_first = n;
  if (accel_ != nullptr) fds[n++] = pollfd{accel_->fd(), POLLIN, 0};
  if (gyro_ != nullptr) fds[n++] = pollfd{gyro_->fd(), POLLIN, 0};
  const int r = sys_.poll(fds, static_cast<nfds_t>(n), timeout_ms);
  const std::int64_t now_ns = monotonic_now_ns();
  if (r < 0) return Status::kIoError;
  if (r == 0) {
    deliver(sink, now_ns);
    return Status::kTimeout;
  }
  for (int i = imu_first; i < n; ++i) {
    IioSensor* sensor = (i == imu_first && accel_ != nullptr) ? accel_.get() : gyro_.get();
    if (fds[i].revents & (POLLERR | POLLHUP | POLLNVAL)) return Status::kIoError;
    if (!(fds[i].revents & POLLIN)) continue;
    for (int round = 0; round < 8; ++round) {  // bounded: a fast producer cannot starve the camera
      std::size_t got = 0;
      if (sensor->read_available(axis_buf_, capacity::kD455IioReadRecords, &got) != Status::kOk) {
        return Status::kIoError;
      }
      for (std::size_t k = 0; k < got; ++k) {
        if (sensor->kind() == ImuKind::kAccel) fuser_.push_accel(axis_buf_[k]);
        else fuser_.push_gyro(axis_buf_[k]);
      }
      if (got < capacity::kD455IioReadRecords) break;
    }
  }
  const bool video_error = imu_first > 0 && (fds[0].revents & (POLLERR | POLLHUP | POLLNVAL)) != 0;
  bool dequeued = false;
  for (;;) {
    StereoFrame f;
    const Status s = camera_->try_dequeue(&f, nullptr);
    if (s == Status::kEmpty) break;
    if (s != Status::kOk) return s;
    dequeued = true;
    if (has_pending_) {  // the camera writes two alternating slots: the older one must go now
      deliver(sink, now_ns);
      if (has_pending_) {
        ++counters_.frames_released_without_imu;
        release_frame(sink);
      }
    }
    pending_ = f;
    has_pending_ = true;
    pending_since_ns_ = now_ns;
  }
  // uvcvideo signals an unplugged device with POLLERR and nothing left to dequeue.
  if (video_error && !dequeued) return Status::kIoError;
  deliver(sink, now_ns);
  return Status::kOk;
}

D455Stats D455Device::stats() const {
  D455Stats s = counters_;
  if (camera_ != nullptr) s.camera = camera_->stats();
  if (accel_ != nullptr) s.accel = accel_->stats();
  if (gyro_ != nullptr) s.gyro = gyro_->stats();
  s.fuser = fuser_.stats();
  return s;
}

}  // namespace ums::d455
