#pragma once
// Rigid transforms as Eigen::Isometry3d (T_a_b maps points of frame b into frame a), plus the
// 7-double pose parameter block of the solver/estimator (docs/math-imu.md, conventions):
//   memory [p.x, p.y, p.z, q.x, q.y, q.z, q.w] (Eigen coefficient order, Hamilton, q = R_w_b),
//   tangent [dp(3), dtheta(3)]: p <- p + dp, q <- q * Exp(dtheta) (right perturbation).

#include <Eigen/Core>
#include <Eigen/Geometry>

namespace ums::se3 {

// T_a_c = T_a_b * T_b_c.
Eigen::Isometry3d compose(const Eigen::Isometry3d& T_a_b, const Eigen::Isometry3d& T_b_c);
// T_b_a from T_a_b (uses R^T, not a general matrix inverse).
Eigen::Isometry3d inverse(const Eigen::Isometry3d& T_a_b);
// p_a = T_a_b * p_b.
Eigen::Vector3d act(const Eigen::Isometry3d& T_a_b, const Eigen::Vector3d& p_b);
// Transform from a rotation (normalised) and a translation.
Eigen::Isometry3d make(const Eigen::Quaterniond& q_a_b, const Eigen::Vector3d& p_a_b);

// SE(3) exponential/logarithm with tangent [rho(3), phi(3)] (translation first, like the pose
// block): T = [Exp(phi), Jl(phi) rho].
Eigen::Isometry3d exp(const Eigen::Matrix<double, 6, 1>& xi);
Eigen::Matrix<double, 6, 1> log(const Eigen::Isometry3d& T);

}  // namespace ums::se3

namespace ums::pose_block {

inline constexpr int kSize = 7;     // ambient doubles
inline constexpr int kTangent = 6;  // local dofs

Eigen::Isometry3d to_isometry(const double* x7);
void from_isometry(const Eigen::Isometry3d& T_w_b, double* x7);
// x_plus = x boxplus delta (right perturbation on the rotation); x_plus may alias x.
void plus(const double* x7, const double* delta6, double* x_plus7);
// delta = x1 boxminus x0 (the inverse of plus: plus(x0, delta) == x1).
void minus(const double* x1, const double* x0, double* delta6);

}  // namespace ums::pose_block
