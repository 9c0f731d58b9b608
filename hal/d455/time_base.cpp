#include "hal/d455/time_base.hpp"

#include <time.h>

#include <stdexcept>
#include <string>

namespace ums::d455 {

std::int64_t monotonic_now_ns() {
  timespec ts{};
  clock_gettime(CLOCK_MONOTONIC, &ts);
  return static_cast<std::int64_t>(ts.tv_sec) * 1000000000LL + ts.tv_nsec;
}

std::int64_t Unwrap32::unwrap(std::uint32_t raw_us) {
  if (!started_) {
    started_ = true;
    last_raw_ = raw_us;
    epoch_us_ = raw_us;  // holds the last unwrapped value
    return epoch_us_;
  }
  // Signed difference modulo 2^32: a small negative step is reordering, a wrap is a small positive
  // step across 2^32.
  const auto diff = static_cast<std::int32_t>(raw_us - last_raw_);
  const std::int64_t out = epoch_us_ + diff;
  if (diff >= 0) {
    last_raw_ = raw_us;
    epoch_us_ = out;
  }
  return out;
}

void ClockMapOptions::validate() const {
  if (!(max_drift_ppm >= 0.0 && max_drift_ppm <= 10000.0)) {
    throw std::runtime_error("ClockMapOptions.max_drift_ppm out of [0, 10000]: " +
                             std::to_string(max_drift_ppm));
  }
}

void DeviceClockMap::observe(std::int64_t device_ns, std::int64_t host_ns) {
  const std::int64_t candidate = host_ns - device_ns;
  if (!have_offset_) {
    have_offset_ = true;
    offset_ns_ = candidate;
    last_host_ns_ = host_ns;
    return;
  }
  const std::int64_t dt_ns = host_ns - last_host_ns_;
  if (dt_ns > 0) {
    offset_ns_ += static_cast<std::int64_t>(static_cast<double>(dt_ns) * options_.max_drift_ppm * 1e-6);
    last_host_ns_ = host_ns;
  }
  if (candidate < offset_ns_) offset_ns_ = candidate;
}

bool OrderGate::accept(std::int64_t t_ns) {
  if (started_ && t_ns == last_ns_) {
    ++duplicates_;
    return false;
  }
  if (started_ && t_ns < last_ns_) {
    ++out_of_order_;
    return false;
  }
  started_ = true;
  last_ns_ = t_ns;
  return true;
}

}  // namespace ums::d455
