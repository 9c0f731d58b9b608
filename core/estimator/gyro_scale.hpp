#pragma once
// The gyroscope's per-axis scale-factor error s as a state of the window (estimate_gyro_scale):
// the gyro measures (1 + s) w + b, so a scale error acts on each IMU interval as a gyro bias of
// s * (its mean measured rate) (imu_factor.hpp). One block of 3 doubles, zero when not estimated;
// a MEMS gyro's scale is good to about 1 %, which a random-walk bias cannot follow in fast turns.

#include <Eigen/Core>

namespace ums {

class GyroScale {
 public:
  Eigen::Vector3d value() const { return Eigen::Vector3d(value_[0], value_[1], value_[2]); }
  double* block() { return value_; }
  const double* block() const { return value_; }
  // Keeps each axis within max_abs (a larger estimate means the window diverged); true when it had to.
  bool clamp(double max_abs) {
    bool clamped = false;
    for (double& v : value_) {
      if (v >= -max_abs && v <= max_abs) continue;
      v = v < -max_abs ? -max_abs : v > max_abs ? max_abs : 0.0;  // NaN: zero
      clamped = true;
    }
    return clamped;
  }
  void reset() { value_[0] = value_[1] = value_[2] = 0.0; }

 private:
  double value_[3] = {0.0, 0.0, 0.0};
};

}  // namespace ums
