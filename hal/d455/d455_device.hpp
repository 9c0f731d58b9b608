#pragma once
// The whole D455 as one source: discovery, the IR stereo pair (V4L2) and the IMU (two IIO devices
// fused into ImuSamples), one clock map shared by both, and time-ordered delivery into a
// MeasurementSink. Order contract: each stream is strictly increasing; a frame is held until an
// IMU sample at or after its stamp has been delivered (or a hold bound expires), so a consumer always has
// the IMU covering a frame when the frame arrives. The IMU may run ahead of frames (it has less
// latency), never behind a delivered frame (counted in imu_behind_frame if it ever happens).

#include <poll.h>

#include <cstdint>
#include <memory>
#include <string>

#include "core/common/capacity.hpp"
#include "core/common/measurement_sink.hpp"
#include "core/common/status.hpp"
#include "hal/d455/discovery.hpp"
#include "hal/d455/iio_imu.hpp"
#include "hal/d455/imu_fuser.hpp"
#include "hal/d455/sys.hpp"
#include "hal/d455/time_base.hpp"
#include "hal/d455/v4l2_camera.hpp"

namespace ums::d455 {

struct D455Options {
  CameraOptions camera;
  ImuOptions imu;
  ClockMapOptions clock;
  bool require_imu = true;        // false: stream images alone when the IIO devices are missing
  int max_frame_hold_ms = 100;    // ms a frame may wait for the IMU to pass its stamp
  void validate() const;          // throws std::runtime_error naming the field and value
};

struct D455Stats {
  CameraStats camera;
  IioStats accel;
  IioStats gyro;
  FuserStats fuser;
  std::uint64_t frames_released_without_imu = 0;  // hold expired or the next frame arrived
  std::uint64_t imu_behind_frame = 0;  // IMU sample delivered after a frame with a later stamp
  std::uint64_t frames = 0;            // delivered to the sink
  std::uint64_t imu_samples = 0;       // delivered to the sink
};

class D455Device {
 public:
  D455Device(Sys& sys, const SysFs& fs, const D455Options& options);
  ~D455Device();
  D455Device(const D455Device&) = delete;
  D455Device& operator=(const D455Device&) = delete;

  // Discovers the device under the SysFs root and configures every node.
  Status open(std::string* error);
  // Configures given nodes (paths rooted like SysFs paths).
  Status open_nodes(const D455Nodes& nodes, std::string* error);
  // start/stop may alternate: stop() halts the camera and closes the IIO devices, start() reopens.
  Status start(std::string* error);
  void stop();

  // Waits up to timeout_ms for data, then delivers everything ready in time order.
  // kOk (something may or may not have been delivered), kTimeout (no descriptor became ready),
  // kIoError (camera or IMU gone: unplugged).
  Status poll_once(MeasurementSink& sink, int timeout_ms);
  // Delivers a held frame now (end of a session).
  void flush(MeasurementSink& sink);

  V4l2Camera& camera() { return *camera_; }
  const D455Nodes& nodes() const { return nodes_; }
  bool has_imu() const { return accel_ != nullptr; }
  D455Stats stats() const;

 private:
  void deliver(MeasurementSink& sink, std::int64_t now_ns);
  void release_frame(MeasurementSink& sink);

  Sys& sys_;
  const SysFs& fs_;
  D455Options options_;
  DeviceClockMap clock_;
  D455Nodes nodes_;
  std::unique_ptr<V4l2Camera> camera_;
  std::unique_ptr<IioSensor> accel_;
  std::unique_ptr<IioSensor> gyro_;
  ImuFuser fuser_;
  StereoFrame pending_;
  bool has_pending_ = false;
  std::int64_t pending_since_ns_ = 0;
  std::int64_t last_frame_t_ns_ = INT64_MIN;
  std::int64_t last_imu_t_ns_ = INT64_MIN;
  ImuAxisSample axis_buf_[capacity::kD455IioReadRecords];
  D455Stats counters_;
};

}  // namespace ums::d455
