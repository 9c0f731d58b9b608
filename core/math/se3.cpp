#include "core/math/se3.hpp"

#include "core/math/so3.hpp"

namespace ums::se3 {

Eigen::Isometry3d compose(const Eigen::Isometry3d& T_a_b, const Eigen::Isometry3d& T_b_c) {
  Eigen::Isometry3d T_a_c = Eigen::Isometry3d::Identity();
  T_a_c.linear() = T_a_b.linear() * T_b_c.linear();
  T_a_c.translation() = T_a_b.linear() * T_b_c.translation() + T_a_b.translation();
  return T_a_c;
}

Eigen::Isometry3d inverse(const Eigen::Isometry3d& T_a_b) {
  Eigen::Isometry3d T_b_a = Eigen::Isometry3d::Identity();
  T_b_a.linear() = T_a_b.linear().transpose();
  T_b_a.translation() = -(T_b_a.linear() * T_a_b.translation());
  return T_b_a;
}

Eigen::Vector3d act(const Eigen::Isometry3d& T_a_b, const Eigen::Vector3d& p_b) {
  return T_a_b.linear() * p_b + T_a_b.translation();
}

Eigen::Isometry3d make(const Eigen::Quaterniond& q_a_b, const Eigen::Vector3d& p_a_b) {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = q_a_b.normalized().toRotationMatrix();
  T.translation() = p_a_b;
  return T;
}

Eigen::Isometry3d exp(const Eigen::Matrix<double, 6, 1>& xi) {
  const Eigen::Vector3d rho = xi.head<3>();
  const Eigen::Vector3d phi = xi.tail<3>();
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = so3::exp(phi);
  T.translation() = so3::left_jacobian(phi) * rho;
  return T;
}

Eigen::Matrix<double, 6, 1> log(const Eigen::Isometry3d& T) {
  Eigen::Matrix<double, 6, 1> xi;
  const Eigen::Vector3d phi = so3::log(Eigen::Matrix3d(T.linear()));
  xi.head<3>() = so3::left_jacobian_inverse(phi) * T.translation();
  xi.tail<3>() = phi;
  return xi;
}

}  // namespace ums::se3

namespace ums::pose_block {

Eigen::Isometry3d to_isometry(const double* x7) {
  const Eigen::Map<const Eigen::Vector3d> p(x7);
  const Eigen::Map<const Eigen::Quaterniond> q(x7 + 3);  // memory (x, y, z, w)
  return se3::make(q, p);
}

void from_isometry(const Eigen::Isometry3d& T_w_b, double* x7) {
  Eigen::Map<Eigen::Vector3d> p(x7);
  Eigen::Map<Eigen::Quaterniond> q(x7 + 3);  // memory (x, y, z, w)
  p = T_w_b.translation();
  q = Eigen::Quaterniond(T_w_b.linear()).normalized();
}

void plus(const double* x7, const double* delta6, double* x_plus7) {
  const Eigen::Map<const Eigen::Vector3d> p(x7);
  const Eigen::Map<const Eigen::Quaterniond> q(x7 + 3);
  const Eigen::Map<const Eigen::Vector3d> dp(delta6);
  const Eigen::Map<const Eigen::Vector3d> dtheta(delta6 + 3);
  // Computed into temporaries first so that x_plus7 may alias x7.
  const Eigen::Vector3d p_new = p + dp;
  const Eigen::Quaterniond q_new = (q * so3::exp_quat(dtheta)).normalized();
  Eigen::Map<Eigen::Vector3d> p_out(x_plus7);
  Eigen::Map<Eigen::Quaterniond> q_out(x_plus7 + 3);
  p_out = p_new;
  q_out = q_new;
}

void minus(const double* x1, const double* x0, double* delta6) {
  const Eigen::Map<const Eigen::Vector3d> p1(x1);
  const Eigen::Map<const Eigen::Vector3d> p0(x0);
  const Eigen::Map<const Eigen::Quaterniond> q1(x1 + 3);
  const Eigen::Map<const Eigen::Quaterniond> q0(x0 + 3);
  Eigen::Map<Eigen::Vector3d> dp(delta6);
  Eigen::Map<Eigen::Vector3d> dtheta(delta6 + 3);
  dp = p1 - p0;
  dtheta = so3::log(q0.conjugate() * q1);
}

}  // namespace ums::pose_block
