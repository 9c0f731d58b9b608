#include "core/imu/saturation.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

namespace ums {
namespace {

// Clamps each axis of v to last +- bound; returns how many axes were clipped. A change equal to
// the bound up to rounding passes (so the sample after a clipped spike is not counted again).
int limit(const Eigen::Vector3d& last, double bound, Eigen::Vector3d* v) {
  int clipped = 0;
  const double tolerance = bound * 1e-9;
  for (int k = 0; k < 3; ++k) {
    const double step = (*v)(k)-last(k);
    if (std::abs(step) > bound + tolerance) {
      (*v)(k) = last(k) + std::clamp(step, -bound, bound);
      ++clipped;
    }
  }
  return clipped;
}

}  // namespace

void SaturationOptions::validate() const {
  if (!(max_gyro_step_rad_s > 0.0) || !std::isfinite(max_gyro_step_rad_s)) {
    throw std::invalid_argument(
        "SaturationOptions.max_gyro_step_rad_s must be finite and > 0, got " +
        std::to_string(max_gyro_step_rad_s));
  }
  if (!(max_accel_step_m_s2 > 0.0) || !std::isfinite(max_accel_step_m_s2)) {
    throw std::invalid_argument(
        "SaturationOptions.max_accel_step_m_s2 must be finite and > 0, got " +
        std::to_string(max_accel_step_m_s2));
  }
}

SaturationElement::SaturationElement(const SaturationOptions& options) : options_(options) {}

void SaturationElement::reset() { has_last_ = false; }

bool SaturationElement::apply(const ImuSample& raw, ImuSample* out) {
  ImuSample s = raw;
  ++processed_samples_;
  int clipped = 0;
  if (options_.enabled && has_last_) {
    clipped += limit(last_.gyro_rad_s, options_.max_gyro_step_rad_s, &s.gyro_rad_s);
    clipped += limit(last_.accel_m_s2, options_.max_accel_step_m_s2, &s.accel_m_s2);
  }
  last_ = s;
  has_last_ = true;
  *out = s;
  if (clipped > 0) {
    ++saturated_samples_;
    saturated_axes_ += static_cast<std::uint64_t>(clipped);
  }
  return clipped > 0;
}

}  // namespace ums
