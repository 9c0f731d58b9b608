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

// Every axis finite and within +-bound (a NaN fails the comparison).
bool within(const Eigen::Vector3d& v, double bound) {
  for (int k = 0; k < 3; ++k) {
    if (!(std::abs(v(k)) <= bound)) return false;
  }
  return true;
}

void require_bound(double value, const char* name) {
  if (!(value > 0.0) || !std::isfinite(value)) {
    throw std::invalid_argument(std::string("SaturationOptions.") + name + " must be finite and > 0, got " +
                                std::to_string(value));
  }
}

}  // namespace

void SaturationOptions::validate() const {
  require_bound(max_gyro_step_rad_s, "max_gyro_step_rad_s");
  require_bound(max_accel_step_m_s2, "max_accel_step_m_s2");
  require_bound(max_abs_gyro_rad_s, "max_abs_gyro_rad_s");
  require_bound(max_abs_accel_m_s2, "max_abs_accel_m_s2");
}

SaturationElement::SaturationElement(const SaturationOptions& options) : options_(options) {}

void SaturationElement::reset() { has_last_ = false; }

bool SaturationElement::plausible(const ImuSample& raw) {
  const bool ok = within(raw.gyro_rad_s, options_.max_abs_gyro_rad_s) && within(raw.accel_m_s2, options_.max_abs_accel_m_s2);
  if (!ok) ++implausible_samples_;
  return ok;
}

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
