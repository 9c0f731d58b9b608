#pragma once
// One HID-sensor IIO device of the D455 (accel_3d or gyro_3d): sysfs configuration (trigger, scan
// elements, sampling frequency, buffer), then non-blocking reads of scan records decoded by their
// `type` descriptions into SI units in the body frame (notes §4).
//
// Body frame convention: body = the D455 IMU axes re-expressed in the left-IR optical frame
// (x right, y down, z forward): v_b = diag(-1, 1, -1) * v_imu_raw (LRS `_imu_2_depth_rot` for the
// D455, notes §4.3). With the camera upright and still, accel reads about (0, -9.81, 0).

#include <cstddef>
#include <cstdint>
#include <string>

#include <Eigen/Core>

#include "core/common/capacity.hpp"
#include "core/common/status.hpp"
#include "hal/d455/iio_scan.hpp"
#include "hal/d455/sys.hpp"
#include "hal/d455/time_base.hpp"

namespace ums::d455 {

enum class ImuKind : std::uint8_t { kAccel, kGyro };

// Which clock the IIO timestamp channel carries.
enum class ImuClock : std::uint8_t {
  kDevice,         // device µs x 1000 (LRS reading, notes §4.4): unwrap the low 32 bits of µs, map
  kHostMonotonic,  // kernel fallback to iio_get_time_ns(); we set current_timestamp_clock=monotonic
};

struct ImuOptions {
  int gyro_hz = 400;               // Hz: 200 or 400
  int accel_hz = 250;              // Hz: 63 or 250 (BMI055), 100, 200 or 400 (BMI085)
  ImuClock clock = ImuClock::kDevice;
  bool use_iio_scale = false;      // true: value x in_*_scale (IIO ABI: m/s^2, rad/s); false: the
                                   // firmware units LRS uses (1 mg; 0.1 or 0.0001 deg/s by realbits)
  bool write_rate_code = true;     // write the hid_fps_translation code 1..4 as LRS does, not Hz
  bool write_hysteresis = true;    // LRS defaults: accel 0.001, gyro 0.1 (notes §4.2 step 5)
  int buffer_length = 128;         // records in the kernel FIFO
  double max_accel_m_s2 = 20.0 * 9.80665;  // m/s^2; larger magnitudes are malformed records
  double max_gyro_rad_s = 40.0;            // rad/s (~2300 deg/s); the range is +-2000 deg/s at most
  void validate() const;           // throws std::runtime_error naming the field and value
};

// One decoded sample of one sensor: SI units, body frame, pipeline clock.
struct ImuAxisSample {
  std::int64_t t_ns = 0;
  Eigen::Vector3d v = Eigen::Vector3d::Zero();  // m/s^2 (accel) or rad/s (gyro)
};

struct IioStats {
  std::uint64_t records = 0;       // decoded and delivered
  std::uint64_t malformed = 0;     // partial record, bad timestamp, impossible magnitude: dropped
  std::uint64_t out_of_order = 0;  // timestamp going back: dropped
  std::uint64_t duplicates = 0;    // same timestamp again: dropped
  std::uint64_t read_errors = 0;   // read() failures other than EAGAIN
};

class IioSensor {
 public:
  IioSensor(Sys& sys, const SysFs& fs, ImuKind kind, const ImuOptions& options, DeviceClockMap* clock);
  ~IioSensor();
  IioSensor(const IioSensor&) = delete;
  IioSensor& operator=(const IioSensor&) = delete;

  // Configures the device at `sysfs_dir` ("/sys/bus/iio/devices/iio:deviceN", rooted), enables the
  // buffer, opens `dev_path` ("/dev/iio:deviceN", rooted) and drops stale records.
  Status open(const std::string& sysfs_dir, const std::string& dev_path, std::string* error);
  void close();

  // Non-blocking: reads what the kernel has (up to `max` samples) into `out`; *n = count written.
  // kOk (possibly n = 0), kIoError when the device is gone.
  Status read_available(ImuAxisSample* out, std::size_t max, std::size_t* n);
  // Decodes a block of raw bytes as read() returned them; host_ns = when they were read.
  // A trailing partial record counts as malformed. Exposed for tests and replay of raw captures.
  std::size_t decode(const std::uint8_t* bytes, std::size_t size, std::int64_t host_ns,
                     ImuAxisSample* out, std::size_t max);

  int fd() const { return fd_; }
  ImuKind kind() const { return kind_; }
  const IioStats& stats() const { return stats_; }
  const IioScanLayout& layout() const { return layout_; }
  double lsb_to_si() const { return lsb_to_si_; }  // SI units per LSB used for x, y, z

 private:
  Sys& sys_;
  const SysFs& fs_;
  ImuKind kind_;
  ImuOptions options_;
  DeviceClockMap* clock_;
  std::string sysfs_dir_;
  int fd_ = -1;
  IioScanLayout layout_;
  int slot_xyz_[3] = {-1, -1, -1};
  int slot_ts_ = -1;
  double lsb_to_si_ = 0.0;
  OrderGate gate_;
  IioStats stats_;
  std::uint8_t read_buf_[capacity::kD455IioReadRecords * capacity::kD455MaxIioRecordBytes] = {};
};

}  // namespace ums::d455
