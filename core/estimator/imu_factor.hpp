#pragma once
// Adapter of the IMU residual of eq. (1) (core/imu/imu_residual.hpp) to the solver's residual
// interface. Blocks: pose_i, speed_bias_i, pose_j, speed_bias_j.

#include "core/imu/imu_residual.hpp"
#include "solver/residual.hpp"

namespace ums {

class ImuFactor final : public solver::ResidualFunction {
 public:
  ImuResidual& residual() { return residual_; }
  const ImuResidual& residual() const { return residual_; }
  int num_residuals() const override { return ImuResidual::kNumResiduals; }
  bool evaluate(const double* const* x, double* r, const solver::JacobianView* jac) const override;

 private:
  ImuResidual residual_;
};

}  // namespace ums
