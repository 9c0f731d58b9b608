#include "solver/manifold.hpp"

#include <cmath>

namespace ums::solver {

Eigen::Quaterniond so3_exp(const Eigen::Vector3d& theta_rad) {
  const double angle_sq = theta_rad.squaredNorm();
  double w = 0.0;
  double k = 0.0;  // sin(angle / 2) / angle
  if (angle_sq < 1e-16) {
    // Taylor terms keep the map smooth and exactly unit-norm to double precision near zero.
    w = 1.0 - angle_sq / 8.0;
    k = 0.5 - angle_sq / 48.0;
  } else {
    const double angle = std::sqrt(angle_sq);
    w = std::cos(0.5 * angle);
    k = std::sin(0.5 * angle) / angle;
  }
  Eigen::Quaterniond q(w, k * theta_rad.x(), k * theta_rad.y(), k * theta_rad.z());
  q.normalize();
  return q;
}

Eigen::Vector3d so3_log(const Eigen::Quaterniond& q_in) {
  // q and -q are the same rotation; w >= 0 picks the angle in [0, pi].
  Eigen::Quaterniond q = q_in;
  if (q.w() < 0.0) q.coeffs() = -q.coeffs();
  const Eigen::Vector3d v = q.vec();
  const double n = v.norm();
  const double w = q.w();
  if (n < 1e-10) {
    // atan2(n, w) / n ~ 1/w - n^2 / (3 w^3)
    return (2.0 / w - 2.0 * n * n / (3.0 * w * w * w)) * v;
  }
  return (2.0 * std::atan2(n, w) / n) * v;
}

Eigen::Matrix3d so3_right_jacobian(const Eigen::Vector3d& phi) {
  const double theta_sq = phi.squaredNorm();
  Eigen::Matrix3d phi_hat;
  phi_hat << 0.0, -phi.z(), phi.y(), phi.z(), 0.0, -phi.x(), -phi.y(), phi.x(), 0.0;
  double a = 0.0;
  double b = 0.0;
  if (theta_sq < 1e-10) {
    a = 0.5 - theta_sq / 24.0;
    b = 1.0 / 6.0 - theta_sq / 120.0;
  } else {
    const double theta = std::sqrt(theta_sq);
    a = (1.0 - std::cos(theta)) / theta_sq;
    b = (theta - std::sin(theta)) / (theta_sq * theta);
  }
  return Eigen::Matrix3d::Identity() - a * phi_hat + b * phi_hat * phi_hat;
}

Eigen::Matrix3d so3_right_jacobian_inverse(const Eigen::Vector3d& phi) {
  const double theta_sq = phi.squaredNorm();
  Eigen::Matrix3d phi_hat;
  phi_hat << 0.0, -phi.z(), phi.y(), phi.z(), 0.0, -phi.x(), -phi.y(), phi.x(), 0.0;
  double c = 0.0;
  if (theta_sq < 1e-10) {
    c = 1.0 / 12.0 + theta_sq / 720.0;
  } else {
    const double theta = std::sqrt(theta_sq);
    c = 1.0 / theta_sq - (1.0 + std::cos(theta)) / (2.0 * theta * std::sin(theta));
  }
  return Eigen::Matrix3d::Identity() + 0.5 * phi_hat + c * phi_hat * phi_hat;
}

void manifold_plus(ManifoldType m, int ambient_size, const double* x, const double* delta,
                   double* x_plus) {
  if (m == ManifoldType::kEuclidean) {
    for (int i = 0; i < ambient_size; ++i) x_plus[i] = x[i] + delta[i];
    return;
  }
  const Eigen::Map<const Eigen::Quaterniond> q(x + 3);
  const Eigen::Map<const Eigen::Vector3d> dtheta(delta + 3);
  const Eigen::Quaterniond q_plus = (q * so3_exp(dtheta)).normalized();
  x_plus[0] = x[0] + delta[0];
  x_plus[1] = x[1] + delta[1];
  x_plus[2] = x[2] + delta[2];
  Eigen::Map<Eigen::Quaterniond>(x_plus + 3) = q_plus;
}

void manifold_minus(ManifoldType m, int ambient_size, const double* y, const double* x,
                    double* delta) {
  if (m == ManifoldType::kEuclidean) {
    for (int i = 0; i < ambient_size; ++i) delta[i] = y[i] - x[i];
    return;
  }
  const Eigen::Map<const Eigen::Quaterniond> q_x(x + 3);
  const Eigen::Map<const Eigen::Quaterniond> q_y(y + 3);
  delta[0] = y[0] - x[0];
  delta[1] = y[1] - x[1];
  delta[2] = y[2] - x[2];
  Eigen::Map<Eigen::Vector3d>(delta + 3) = so3_log(q_x.conjugate() * q_y);
}

}  // namespace ums::solver
