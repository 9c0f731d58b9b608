#pragma once
// The other half of a tightly coupled relocation (relocation.hpp): the loop keyframe's own stereo
// point of a shared landmark, fixed in the loop keyframe's left camera, seen by a window frame's
// left camera. It is BearingResidual (same camera, two frames) with the inverse distance held
// (not a parameter): blocks pose_loop, pose_t, T_b_c0. With the window landmark seen by the loop
// keyframe, both keyframes' depths count, as in the loop verifier's two-way fit.

#include <Eigen/Core>

#include "core/estimator/bearing_residual.hpp"

namespace ums {

class LoopPointResidual final : public solver::ResidualFunction {
 public:
  // p_c0: m, the point in the loop keyframe's left camera; b_target: the window frame's measured
  // unit bearing (left camera); weight: as BearingResidual's.
  void set(const Eigen::Vector3d& p_c0, const Eigen::Vector3d& b_target, double weight) {
    rho_ = 1.0 / p_c0.norm();
    bearing_.set(BearingResidual::Kind::kTwoFrames, true, p_c0 * rho_, b_target, weight);
  }
  int num_residuals() const override { return 2; }
  bool evaluate(const double* const* parameters, double* residuals,
                const solver::JacobianView* jacobians) const override {
    const double* p[4] = {parameters[0], parameters[1], parameters[2], &rho_};
    if (jacobians == nullptr) return bearing_.evaluate(p, residuals, nullptr);
    const solver::JacobianView j[4] = {jacobians[0], jacobians[1], jacobians[2], solver::JacobianView{}};
    return bearing_.evaluate(p, residuals, j);
  }

 private:
  BearingResidual bearing_;
  double rho_ = 1.0;  // 1/m
};

}  // namespace ums
