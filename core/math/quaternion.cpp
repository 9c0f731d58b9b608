#include "core/math/quaternion.hpp"

#include <cmath>

#include "core/math/so3.hpp"

namespace ums::quat {

Eigen::Vector4d to_wxyz(const Eigen::Quaterniond& q) {
  return Eigen::Vector4d(q.w(), q.x(), q.y(), q.z());
}

Eigen::Quaterniond from_wxyz(const Eigen::Vector4d& wxyz) {
  return Eigen::Quaterniond(wxyz(0), wxyz(1), wxyz(2), wxyz(3));
}

Eigen::Matrix4d left(const Eigen::Quaterniond& p) {
  Eigen::Matrix4d m;
  m(0, 0) = p.w();
  m.block<1, 3>(0, 1) = -p.vec().transpose();
  m.block<3, 1>(1, 0) = p.vec();
  m.block<3, 3>(1, 1) = p.w() * Eigen::Matrix3d::Identity() + so3::hat(p.vec());
  return m;
}

Eigen::Matrix4d right(const Eigen::Quaterniond& q) {
  Eigen::Matrix4d m;
  m(0, 0) = q.w();
  m.block<1, 3>(0, 1) = -q.vec().transpose();
  m.block<3, 1>(1, 0) = q.vec();
  m.block<3, 3>(1, 1) = q.w() * Eigen::Matrix3d::Identity() - so3::hat(q.vec());
  return m;
}

Eigen::Quaterniond normalized_positive(const Eigen::Quaterniond& q) {
  const double n = q.norm();
  if (!(n > 1e-300)) return Eigen::Quaterniond::Identity();
  Eigen::Quaterniond out = q;
  out.coeffs() /= (q.w() < 0.0 ? -n : n);
  return out;
}

Eigen::Quaterniond small_angle(const Eigen::Vector3d& dtheta_rad) {
  const Eigen::Vector3d h = 0.5 * dtheta_rad;
  return Eigen::Quaterniond(1.0, h.x(), h.y(), h.z()).normalized();
}

double yaw(const Eigen::Matrix3d& R_w_b) { return std::atan2(R_w_b(1, 0), R_w_b(0, 0)); }

double wrap_angle_rad(double a_rad) {
  const double w = std::remainder(a_rad, 2.0 * M_PI);  // [-pi, pi]
  return w <= -M_PI ? w + 2.0 * M_PI : w;
}

Eigen::Matrix3d remove_yaw(const Eigen::Matrix3d& R_w_b) {
  const double psi = yaw(R_w_b);
  return Eigen::AngleAxisd(-psi, Eigen::Vector3d::UnitZ()).toRotationMatrix() * R_w_b;
}

}  // namespace ums::quat
