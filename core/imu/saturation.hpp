#pragma once
// The saturation element of paper Section III-A.2: before preintegration, the change of each
// raw accelerometer and gyro axis from one sample to the next is limited to a bound, so that an
// impulse or saw-tooth spike cannot inject a large false increment. The limit is applied against
// the previous OUTPUT sample (a slew-rate limiter): after a one-sample spike the next normal sample
// passes unchanged, and a genuine large step is followed within a few samples.
//
// Bounds are per sample (not per second): they are chosen for the IMU rate at hand. The defaults
// are about 3x the largest change measured on the whole EuRoC V1_01 flight at 200 Hz (gyro 0.303
// rad/s, accel 10.2 m/s^2 per sample; docs/math-imu.md), so they never touch normal EuRoC motion
// and still cut a 50 m/s^2 impulse.
//
// Ahead of the limiter, a reading that no sensor could have made (not finite, or beyond the
// widest range MEMS IMUs offer: 4000 deg/s, 32 g) is not a measurement at all: limiting it would
// still ramp a sustained glitch in, and a NaN would pass every comparison. plausible() tells the
// caller to drop it; the preintegration then bridges the one-sample hole like any other.

#include <cstdint>

#include "core/common/imu_sample.hpp"

namespace ums {

struct SaturationOptions {
  bool enabled = true;
  double max_gyro_step_rad_s = 1.0;   // rad/s, per axis, between consecutive samples
  double max_accel_step_m_s2 = 30.0;  // m/s^2, per axis, between consecutive samples
  double max_abs_gyro_rad_s = 70.0;   // rad/s, per axis: beyond 4000 deg/s is no gyro reading
  double max_abs_accel_m_s2 = 320.0;  // m/s^2, per axis: beyond 32 g is no accelerometer reading

  void validate() const;  // throws std::invalid_argument naming the field and value
};

class SaturationElement {
 public:
  explicit SaturationElement(const SaturationOptions& options = SaturationOptions());

  // False for a sample that is no reading (an axis not finite or beyond the sensor range);
  // counted in implausible_samples(). Such a sample must not reach apply().
  bool plausible(const ImuSample& raw);
  // Forget the previous sample (the next one passes unchanged). Counters are kept.
  void reset();
  // Writes the limited sample into *out (may alias &raw); returns true if any axis was clipped.
  bool apply(const ImuSample& raw, ImuSample* out);

  std::uint64_t saturated_samples() const {
    return saturated_samples_;
  }  // stats.json imu.saturated_samples
  std::uint64_t saturated_axes() const { return saturated_axes_; }  // clipped axis values
  std::uint64_t processed_samples() const { return processed_samples_; }
  std::uint64_t implausible_samples() const { return implausible_samples_; }  // imu.implausible_samples

 private:
  SaturationOptions options_;
  ImuSample last_;
  bool has_last_ = false;
  std::uint64_t saturated_samples_ = 0;
  std::uint64_t saturated_axes_ = 0;
  std::uint64_t processed_samples_ = 0;
  std::uint64_t implausible_samples_ = 0;
};

}  // namespace ums
