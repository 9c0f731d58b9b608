#include "core/estimator/state_residuals.hpp"

#include <cmath>

#include <Eigen/Geometry>

#include "core/math/so3.hpp"

namespace ums {

void SpeedBiasPrior::set(const Vector9& target, const Vector9& sigma) {
  target_ = target;
  for (int i = 0; i < 9; ++i) weight_[i] = sigma[i] > 0.0 ? 1.0 / sigma[i] : 0.0;
}

bool SpeedBiasPrior::evaluate(const double* const* x, double* r, const solver::JacobianView* jac) const {
  const Eigen::Map<const Vector9> sb(x[0]);
  Eigen::Map<Vector9> res(r);
  res = weight_.cwiseProduct(sb - target_);
  if (jac != nullptr && jac[0].wanted()) {
    auto J = solver::jacobian_map<9, 9>(jac[0]);
    J.setZero();
    for (int i = 0; i < 9; ++i) J(i, i) = weight_[i];
  }
  return res.allFinite();
}

bool StillResidual::evaluate(const double* const* x, double* r, const solver::JacobianView* jac) const {
  const Eigen::Map<const Eigen::Vector3d> p_i(x[0]), p_j(x[1]);
  const Eigen::Map<const Eigen::Quaterniond> q_i(x[0] + 3), q_j(x[1] + 3);
  Eigen::Map<Eigen::Matrix<double, 6, 1>> res(r);
  const Eigen::Vector3d e = so3::log(Eigen::Quaterniond(q_i.conjugate() * q_j));
  res.head<3>() = w_p_ * (p_j - p_i);
  res.tail<3>() = w_r_ * e;
  if (jac == nullptr) return res.allFinite();
  const Eigen::Matrix3d Jr_inv = so3::right_jacobian_inverse(e);
  if (jac[0].wanted()) {
    auto J = solver::jacobian_map<6, 6>(jac[0]);
    J.setZero();
    J.topLeftCorner<3, 3>() = -w_p_ * Eigen::Matrix3d::Identity();
    // d Log(Exp(-d) R_ij) / d d = -Jl^-1(e) = -Jr^-1(e) R_ij^T.
    J.bottomRightCorner<3, 3>() = -w_r_ * Jr_inv * so3::exp(e).transpose();
  }
  if (jac[1].wanted()) {
    auto J = solver::jacobian_map<6, 6>(jac[1]);
    J.setZero();
    J.topLeftCorner<3, 3>() = w_p_ * Eigen::Matrix3d::Identity();
    J.bottomRightCorner<3, 3>() = w_r_ * Jr_inv;
  }
  return res.allFinite();
}

void PosePrior::set(const Eigen::Vector3d& p0, const Eigen::Quaterniond& q0, double sigma_m, double sigma_rad) {
  p0_ = p0;
  q0_ = q0.normalized();
  w_p_ = 1.0 / sigma_m;
  w_r_ = 1.0 / sigma_rad;
}

bool PosePrior::evaluate(const double* const* x, double* r, const solver::JacobianView* jac) const {
  const Eigen::Map<const Eigen::Vector3d> p(x[0]);
  const Eigen::Map<const Eigen::Quaterniond> q(x[0] + 3);
  Eigen::Map<Eigen::Matrix<double, 6, 1>> res(r);
  const Eigen::Vector3d e = so3::log(Eigen::Quaterniond(q0_.conjugate() * q));
  res.head<3>() = w_p_ * (p - p0_);
  res.tail<3>() = w_r_ * e;
  if (jac != nullptr && jac[0].wanted()) {
    auto J = solver::jacobian_map<6, 6>(jac[0]);
    J.setZero();
    J.topLeftCorner<3, 3>() = w_p_ * Eigen::Matrix3d::Identity();
    J.bottomRightCorner<3, 3>() = w_r_ * so3::right_jacobian_inverse(e);
  }
  return res.allFinite();
}

void RelativePosePrior::set(const Eigen::Vector3d& t_ab, const Eigen::Quaterniond& q_ab, double sigma_m,
                            double sigma_rad) {
  t_ab_ = t_ab;
  q_ab_ = q_ab.normalized();
  w_p_ = 1.0 / sigma_m;
  w_r_ = 1.0 / sigma_rad;
}

bool RelativePosePrior::evaluate(const double* const* x, double* r, const solver::JacobianView* jac) const {
  const Eigen::Map<const Eigen::Vector3d> p_a(x[0]), p_b(x[1]);
  const Eigen::Map<const Eigen::Quaterniond> q_a(x[0] + 3), q_b(x[1] + 3);
  const Eigen::Matrix3d R_a_t = q_a.toRotationMatrix().transpose();
  const Eigen::Vector3d d = R_a_t * (p_b - p_a);
  const Eigen::Matrix3d E = (q_ab_.conjugate() * q_a.conjugate() * q_b).toRotationMatrix();
  const Eigen::Vector3d e = so3::log(E);
  Eigen::Map<Eigen::Matrix<double, 6, 1>> res(r);
  res.head<3>() = w_p_ * (d - t_ab_);
  res.tail<3>() = w_r_ * e;
  if (jac == nullptr) return res.allFinite();
  const Eigen::Matrix3d Jr_inv = so3::right_jacobian_inverse(e);
  if (jac[0].wanted()) {
    auto J = solver::jacobian_map<6, 6>(jac[0]);
    J.setZero();
    J.topLeftCorner<3, 3>() = -w_p_ * R_a_t;
    // R_a Exp(t): R_a^T -> Exp(-t) R_a^T, so d moves by [d]x t.
    J.block<3, 3>(0, 3) = w_p_ * so3::hat(d);
    // q_ab^-1 Exp(-t) q_a^-1 q_b = E Exp(-E^T R_ab^T t).
    J.bottomRightCorner<3, 3>() = -w_r_ * Jr_inv * E.transpose() * q_ab_.toRotationMatrix().transpose();
  }
  if (jac[1].wanted()) {
    auto J = solver::jacobian_map<6, 6>(jac[1]);
    J.setZero();
    J.topLeftCorner<3, 3>() = w_p_ * R_a_t;
    J.bottomRightCorner<3, 3>() = w_r_ * Jr_inv;
  }
  return res.allFinite();
}

bool ScalarPrior::evaluate(const double* const* x, double* r, const solver::JacobianView* jac) const {
  r[0] = w_ * (x[0][0] - x0_);
  if (jac != nullptr && jac[0].wanted()) solver::jacobian_map<1, 1>(jac[0])(0, 0) = w_;
  return std::isfinite(r[0]);
}

bool Vector3Prior::evaluate(const double* const* x, double* r, const solver::JacobianView* jac) const {
  for (int a = 0; a < 3; ++a) r[a] = w_ * (x[0][a] - x0_[a]);
  if (jac != nullptr && jac[0].wanted()) solver::jacobian_map<3, 3>(jac[0]) = w_ * Eigen::Matrix3d::Identity();
  return std::isfinite(r[0]) && std::isfinite(r[1]) && std::isfinite(r[2]);
}

}  // namespace ums
