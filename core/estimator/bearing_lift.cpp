#include "core/estimator/bearing_lift.hpp"

#include <cmath>

#include <Eigen/Geometry>

#include "core/estimator/bearing_residual.hpp"
#include "core/math/so3.hpp"

namespace ums {

void BearingLift::set(const Eigen::Vector3d& b_host) { b_host_ = BearingResidual::unit(b_host); }

bool BearingLift::evaluate(const double* const* parameters, double* G) const {
  const double rho = parameters[1][0];
  if (!(rho > 1e-6) || !std::isfinite(rho)) return false;
  const Eigen::Map<const Eigen::Quaterniond> q_w_bh(parameters[0] + 3);
  const Eigen::Map<const Eigen::Vector3d> p_b_ch(parameters[2]);
  const Eigen::Map<const Eigen::Quaterniond> q_b_ch(parameters[2] + 3);
  const Eigen::Matrix3d R_w_bh = q_w_bh.toRotationMatrix();
  const Eigen::Matrix3d R_b_ch = q_b_ch.toRotationMatrix();
  const double inv_rho = 1.0 / rho;
  const Eigen::Vector3d P_ch = b_host_ * inv_rho;
  const Eigen::Vector3d P_bh = R_b_ch * P_ch + p_b_ch;
  // The pose's tangent moves p_w_bh by dp and rotates the body by Exp(dtheta) on the right
  // (solver/manifold.hpp): d P_w / d dtheta = -R_w_bh hat(P_bh).
  Eigen::Map<Eigen::Matrix<double, 3, 7, Eigen::RowMajor>> J(G);
  J.leftCols<3>().setIdentity();
  J.block<3, 3>(0, 3) = -R_w_bh * so3::hat(P_bh);
  J.col(6) = R_w_bh * (R_b_ch * (-P_ch * inv_rho));
  return true;
}

}  // namespace ums
