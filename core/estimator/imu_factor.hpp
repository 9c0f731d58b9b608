#pragma once
// Adapter of the IMU residual of eq. (1) (core/imu/imu_residual.hpp) to the solver's residual
// interface. Blocks: pose_i, speed_bias_i, pose_j, speed_bias_j, and with the gyro scale
// (estimate_gyro_scale, gyro_scale.hpp) a fifth: the scale-factor error s (3). It enters as a gyro
// bias of s * w_mean (the interval's mean measured rate) added at both ends, so the
// preintegration is corrected through its bias Jacobian and the bias random walk between the ends
// is unchanged; exact to first order for a rate constant over the interval.

#include "core/imu/imu_residual.hpp"
#include "solver/residual.hpp"

namespace ums {

class ImuFactor final : public solver::ResidualFunction {
 public:
  ImuResidual& residual() { return residual_; }
  const ImuResidual& residual() const { return residual_; }
  // Whether the next evaluations read the fifth block (set by whoever adds the factor).
  void set_gyro_scale(bool on) { gyro_scale_ = on; }
  bool gyro_scale() const { return gyro_scale_; }
  int num_residuals() const override { return ImuResidual::kNumResiduals; }
  bool evaluate(const double* const* x, double* r, const solver::JacobianView* jac) const override;

 private:
  // rad/s: the mean of the interval's measured rates (its samples, bias included: s * b is
  // below 1e-4 rad/s for any MEMS gyro).
  Eigen::Vector3d mean_rate_rad_s() const;

  ImuResidual residual_;
  bool gyro_scale_ = false;
};

}  // namespace ums
