#pragma once
// The point through which a landmark's bearing residuals (bearing_residual.hpp) see its host pose
// and its inverse depth: the landmark in the world,
//   P_w = T_w_bh (T_b_ch (b_h / rho)),
// with b_h the measured unit bearing of the host observation. The solver (solver::PointLift) takes
// d P_w / d (host pose, rho) from here once per landmark and pass, and d r / d P_w from each
// residual, instead of each residual's own host and inverse-depth Jacobians.
// Parameters, in this order: pose_h (7), rho (1), T_b_ch (7). Not for residuals with a time
// offset block (the host bearing would move with td): the builder sets no lift then.

#include <Eigen/Core>

#include "solver/residual.hpp"

namespace ums {

class BearingLift final : public solver::PointLift {
 public:
  // b_host: the landmark's host bearing, as given to its residuals' BearingResidual::set.
  void set(const Eigen::Vector3d& b_host);
  // G (3 x 7, row-major): d P_w / d (pose_h tangent [dp, dtheta], rho).
  bool evaluate(const double* const* parameters, double* G) const override;

 private:
  Eigen::Vector3d b_host_ = Eigen::Vector3d::UnitZ();
};

}  // namespace ums
