#include "hal/d455/iio_imu.hpp"

#include <fcntl.h>
#include <time.h>

#include <cerrno>
#include <cmath>
#include <cstdlib>
#include <stdexcept>

namespace ums::d455 {

namespace {

constexpr double kG = 9.80665;               // m/s^2 per g (LRS accel conversion)
constexpr double kDegToRad = 3.14159265358979323846 / 180.0;

// hid_fps_translation as LRS writes it (notes §4.2 step 4): the code, not Hz.
int rate_code(int hz) {
  switch (hz) {
    case 63:
    case 100: return 1;
    case 200: return 2;
    case 250: return 3;
    case 400: return 4;
    default: return -1;
  }
}

}  // namespace

void ImuOptions::validate() const {
  if (gyro_hz != 200 && gyro_hz != 400) {
    throw std::runtime_error("d455 imu: gyro_hz must be 200 or 400, got " + std::to_string(gyro_hz));
  }
  if (rate_code(accel_hz) < 0) {
    throw std::runtime_error("d455 imu: accel_hz must be 63, 100, 200, 250 or 400, got " +
                             std::to_string(accel_hz));
  }
  if (buffer_length < 2 || buffer_length > 4096) {
    throw std::runtime_error("d455 imu: buffer_length must be in [2, 4096], got " + std::to_string(buffer_length));
  }
  if (!(max_accel_m_s2 > 0.0) || !(max_gyro_rad_s > 0.0)) {
    throw std::runtime_error("d455 imu: max_accel_m_s2 and max_gyro_rad_s must be > 0");
  }
}

IioSensor::IioSensor(Sys& sys, const SysFs& fs, ImuKind kind, const ImuOptions& options, DeviceClockMap* clock)
    : sys_(sys), fs_(fs), kind_(kind), options_(options), clock_(clock) {
  options_.validate();
}

IioSensor::~IioSensor() { close(); }

Status IioSensor::open(const std::string& sysfs_dir, const std::string& dev_path, std::string* error) {
  close();
  sysfs_dir_ = sysfs_dir;
  const bool accel = kind_ == ImuKind::kAccel;
  const std::string want = accel ? "accel_3d" : "gyro_3d";
  const std::string prefix = accel ? "in_accel_" : "in_anglvel_";
  std::string name;
  if (!fs_.read_text(sysfs_dir + "/name", &name) || name != want) {
    *error = "d455 imu: " + sysfs_dir + "/name is '" + name + "', expected " + want;
    return Status::kUnsupported;
  }
  // Something may have enabled the buffer at plug time (notes §7.10): release it before configuring.
  fs_.write_text(sysfs_dir + "/buffer/enable", "0");
  if (options_.clock == ImuClock::kHostMonotonic) fs_.write_text(sysfs_dir + "/current_timestamp_clock", "monotonic");

  // Trigger "<name>-dev<N>" (full device number, notes §4.2 step 2).
  const std::string leaf = sysfs_dir.substr(sysfs_dir.find_last_of('/') + 1);
  const std::string trigger = want + "-dev" + std::to_string(trailing_number(leaf));
  if (fs_.exists(sysfs_dir + "/trigger/current_trigger") &&
      !fs_.write_text(sysfs_dir + "/trigger/current_trigger", trigger)) {
    *error = "d455 imu: cannot write " + trigger + " to " + sysfs_dir + "/trigger/current_trigger";
    return Status::kIoError;
  }

  // Scan elements: x, y, z and the timestamp; every other channel off.
  layout_ = IioScanLayout{};
  slot_xyz_[0] = slot_xyz_[1] = slot_xyz_[2] = slot_ts_ = -1;
  const std::string scan = sysfs_dir + "/scan_elements";
  const char* axes[3] = {"x", "y", "z"};
  for (const std::string& entry : fs_.list(scan)) {
    if (entry.size() < 4 || entry.compare(entry.size() - 3, 3, "_en") != 0) continue;
    const std::string channel = entry.substr(0, entry.size() - 3);
    int axis = -1;
    for (int a = 0; a < 3; ++a) {
      if (channel == prefix + axes[a]) axis = a;
    }
    const bool is_ts = channel == "in_timestamp";
    if (axis < 0 && !is_ts) {
      fs_.write_text(scan + "/" + entry, "0");
      continue;
    }
    std::string type_text, index_text;
    IioChannelType type;
    if (!fs_.read_text(scan + "/" + channel + "_type", &type_text) || !parse_iio_type(type_text, &type)) {
      *error = "d455 imu: " + scan + "/" + channel + "_type unreadable or malformed: '" + type_text + "'";
      return Status::kUnsupported;
    }
    if (!fs_.read_text(scan + "/" + channel + "_index", &index_text)) {
      *error = "d455 imu: " + scan + "/" + channel + "_index unreadable";
      return Status::kUnsupported;
    }
    if (!fs_.write_text(scan + "/" + entry, "1")) {
      *error = "d455 imu: cannot enable " + scan + "/" + entry;
      return Status::kIoError;
    }
    const int slot = layout_.add(std::atoi(index_text.c_str()), type);
    if (is_ts) slot_ts_ = slot;
    else slot_xyz_[axis] = slot;
  }
  if (slot_xyz_[0] < 0 || slot_xyz_[1] < 0 || slot_xyz_[2] < 0 || slot_ts_ < 0 || !layout_.finalize() ||
      layout_.record_bytes() > static_cast<int>(capacity::kD455MaxIioRecordBytes)) {
    *error = "d455 imu: " + scan + " lacks " + prefix + "{x,y,z} or in_timestamp, or has an unusable "
             "layout (the gyro timestamp channel needs kernel >= 5.12, notes §1.4)";
    return Status::kUnsupported;
  }

  // Units. LRS ignores in_*_scale; the firmware already reports 1 mg and 0.1 (16-bit) or 0.0001
  // (32-bit, FW >= 5.16) deg/s per LSB (notes §4.3).
  const int realbits = layout_.at(slot_xyz_[0]).type.bits;
  if (options_.use_iio_scale) {
    std::string scale_text;
    if (!fs_.read_text(sysfs_dir + "/" + prefix + "scale", &scale_text)) {
      *error = "d455 imu: use_iio_scale set but " + sysfs_dir + "/" + prefix + "scale is unreadable";
      return Status::kUnsupported;
    }
    lsb_to_si_ = std::strtod(scale_text.c_str(), nullptr);
  } else if (accel) {
    lsb_to_si_ = 0.001 * kG;
  } else {
    lsb_to_si_ = (realbits > 16 ? 0.0001 : 0.1) * kDegToRad;
  }
  if (!(lsb_to_si_ > 0.0)) {
    *error = "d455 imu: scale for " + sysfs_dir + " is not positive";
    return Status::kUnsupported;
  }

  const int hz = accel ? options_.accel_hz : options_.gyro_hz;
  const std::string rate = std::to_string(options_.write_rate_code ? rate_code(hz) : hz);
  bool rate_written = false;
  for (const std::string& entry : fs_.list(sysfs_dir)) {
    if (entry.find("sampling_frequency") != std::string::npos && entry.find("available") == std::string::npos) {
      rate_written = fs_.write_text(sysfs_dir + "/" + entry, rate) || rate_written;
    }
  }
  if (!rate_written) {
    *error = "d455 imu: no writable *sampling_frequency attribute in " + sysfs_dir;
    return Status::kIoError;
  }
  if (options_.write_hysteresis) {
    for (const std::string& entry : fs_.list(sysfs_dir)) {
      if (entry.find("hysteresis") != std::string::npos && entry.find("available") == std::string::npos) {
        fs_.write_text(sysfs_dir + "/" + entry, accel ? "0.001" : "0.1");
      }
    }
  }
  fs_.write_text(sysfs_dir + "/buffer/length", std::to_string(options_.buffer_length));
  if (!fs_.write_text(sysfs_dir + "/buffer/enable", "1")) {
    *error = "d455 imu: cannot enable " + sysfs_dir + "/buffer (permissions? see docs/hal-d455.md udev rule)";
    return Status::kIoError;
  }
  const std::string host_dev = fs_.host_path(dev_path);
  for (int attempt = 0; attempt < 10 && fd_ < 0; ++attempt) {
    const int fd = sys_.open(host_dev.c_str(), O_RDONLY | O_NONBLOCK);
    if (fd >= 0) {
      fd_ = fd;
      break;
    }
    timespec wait{0, 5 * 1000 * 1000};  // the char device may appear a little after enabling
    nanosleep(&wait, nullptr);
  }
  if (fd_ < 0) {
    *error = "d455 imu: cannot open " + host_dev;
    fs_.write_text(sysfs_dir + "/buffer/enable", "0");
    return Status::kIoError;
  }
  // Stale records from before this session would arrive with old timestamps: flush them.
  for (int i = 0; i < 1000; ++i) {
    if (sys_.read(fd_, read_buf_, sizeof read_buf_) <= 0) break;
  }
  return Status::kOk;
}

void IioSensor::close() {
  if (fd_ >= 0) {
    sys_.close(fd_);
    fd_ = -1;
    fs_.write_text(sysfs_dir_ + "/buffer/enable", "0");
  }
}

std::size_t IioSensor::decode(const std::uint8_t* bytes, std::size_t size, std::int64_t host_ns,
                              ImuAxisSample* out, std::size_t max) {
  const auto rec = static_cast<std::size_t>(layout_.record_bytes());
  if (rec == 0) return 0;
  std::size_t n = 0;
  std::size_t pos = 0;
  const double limit = kind_ == ImuKind::kAccel ? options_.max_accel_m_s2 : options_.max_gyro_rad_s;
  for (; pos + rec <= size && n < max; pos += rec) {
    const std::uint8_t* r = bytes + pos;
    const std::int64_t ts = iio_extract(r, layout_.at(slot_ts_));
    const Eigen::Vector3d raw(static_cast<double>(iio_extract(r, layout_.at(slot_xyz_[0]))),
                              static_cast<double>(iio_extract(r, layout_.at(slot_xyz_[1]))),
                              static_cast<double>(iio_extract(r, layout_.at(slot_xyz_[2]))));
    // IMU axes -> body (left-IR optical axes): diag(-1, 1, -1).
    const Eigen::Vector3d v(-raw.x() * lsb_to_si_, raw.y() * lsb_to_si_, -raw.z() * lsb_to_si_);
    if (ts <= 0 || !(v.norm() <= limit)) {
      ++stats_.malformed;
      continue;
    }
    std::int64_t t_ns = ts;
    if (options_.clock == ImuClock::kDevice && clock_ != nullptr) {
      // LRS: iio value / 1000 = device µs, low 32 bits (same counter as the UVC PTS).
      const std::int64_t dev_us = clock_->unwrap_us(static_cast<std::uint32_t>(ts / 1000));
      clock_->observe(dev_us * 1000, host_ns);
      t_ns = clock_->to_host_ns(dev_us * 1000);
    }
    if (!gate_.accept(t_ns)) {
      stats_.out_of_order = gate_.out_of_order();
      stats_.duplicates = gate_.duplicates();
      continue;
    }
    out[n].t_ns = t_ns;
    out[n].v = v;
    ++n;
    ++stats_.records;
  }
  if (pos < size && size - pos < rec) ++stats_.malformed;  // a trailing partial record
  return n;
}

Status IioSensor::read_available(ImuAxisSample* out, std::size_t max, std::size_t* n) {
  *n = 0;
  if (fd_ < 0) return Status::kIoError;
  const auto rec = static_cast<std::size_t>(layout_.record_bytes());
  std::size_t want = (max < capacity::kD455IioReadRecords ? max : capacity::kD455IioReadRecords) * rec;
  if (want == 0) return Status::kOk;
  const ssize_t got = sys_.read(fd_, read_buf_, want);
  if (got == -EAGAIN || got == 0) return Status::kOk;
  if (got < 0) {
    ++stats_.read_errors;
    return Status::kIoError;
  }
  *n = decode(read_buf_, static_cast<std::size_t>(got), monotonic_now_ns(), out, max);
  return Status::kOk;
}

}  // namespace ums::d455
