#include "core/math/so3.hpp"

#include <cmath>

namespace ums::so3 {
namespace {

// Below this angle the closed forms lose digits to cancellation and Taylor series take over.
constexpr double kTinyAngle = 1e-5;   // rad, for sin(t)/t-type terms (error ~ t^4 ~ 1e-20)
constexpr double kSmallAngle = 1e-2;  // rad, for (t - sin t)/t^3-type terms (3 Taylor terms)

}  // namespace

Eigen::Matrix3d hat(const Eigen::Vector3d& v) {
  Eigen::Matrix3d m;
  m << 0.0, -v.z(), v.y(),  //
      v.z(), 0.0, -v.x(),   //
      -v.y(), v.x(), 0.0;
  return m;
}

Eigen::Vector3d vee(const Eigen::Matrix3d& m) {
  return 0.5 * Eigen::Vector3d(m(2, 1) - m(1, 2), m(0, 2) - m(2, 0), m(1, 0) - m(0, 1));
}

Eigen::Matrix3d exp(const Eigen::Vector3d& phi) {
  const double t2 = phi.squaredNorm();
  const double t = std::sqrt(t2);
  double a;  // sin(t)/t
  double b;  // (1 - cos t)/t^2, written 2 sin^2(t/2)/t^2 to avoid the cancellation of 1 - cos t
  if (t < kTinyAngle) {
    a = 1.0 - t2 / 6.0;
    b = 0.5 - t2 / 24.0;
  } else {
    a = std::sin(t) / t;
    const double s = std::sin(0.5 * t);
    b = 2.0 * s * s / t2;
  }
  const Eigen::Matrix3d K = hat(phi);
  return Eigen::Matrix3d::Identity() + a * K + b * K * K;
}

Eigen::Quaterniond exp_quat(const Eigen::Vector3d& phi) {
  const double t2 = phi.squaredNorm();
  const double t = std::sqrt(t2);
  double half_sinc;  // sin(t/2)/t
  double c;
  if (t < kTinyAngle) {
    half_sinc = 0.5 - t2 / 48.0;
    c = 1.0 - t2 / 8.0;
  } else {
    half_sinc = std::sin(0.5 * t) / t;
    c = std::cos(0.5 * t);
  }
  const Eigen::Vector3d v = half_sinc * phi;
  return Eigen::Quaterniond(c, v.x(), v.y(), v.z());
}

Eigen::Vector3d log(const Eigen::Quaterniond& q_in) {
  Eigen::Quaterniond q = q_in;
  const double n = q.norm();
  if (n > 0.0) q.coeffs() /= n;
  // q and -q are the same rotation: choose w >= 0 so that the angle lands in [0, pi].
  if (q.w() < 0.0) q.coeffs() = -q.coeffs();
  const Eigen::Vector3d v = q.vec();
  const double s = v.norm();
  if (s < kTinyAngle) {
    // atan2(s, w) ~= s/w (1 - s^2/(3 w^2)); w ~ 1 here.
    const double w = q.w();
    return (2.0 / w) * (1.0 - s * s / (3.0 * w * w)) * v;
  }
  // atan2 stays accurate near pi, where w -> 0 and s -> 1.
  const double t = 2.0 * std::atan2(s, q.w());
  return (t / s) * v;
}

Eigen::Vector3d log(const Eigen::Matrix3d& R) {
  // Eigen's matrix -> quaternion conversion picks the largest diagonal pivot (Shepperd), which
  // keeps the axis accurate near pi where the antisymmetric part of R vanishes.
  return log(Eigen::Quaterniond(R));
}

Eigen::Matrix3d right_jacobian(const Eigen::Vector3d& phi) {
  const double t2 = phi.squaredNorm();
  const double t = std::sqrt(t2);
  double b;  // (1 - cos t)/t^2
  double c;  // (t - sin t)/t^3
  if (t < kSmallAngle) {
    b = 0.5 - t2 / 24.0 + t2 * t2 / 720.0;
    c = 1.0 / 6.0 - t2 / 120.0 + t2 * t2 / 5040.0;
  } else {
    const double s = std::sin(0.5 * t);
    b = 2.0 * s * s / t2;
    c = (t - std::sin(t)) / (t2 * t);
  }
  const Eigen::Matrix3d K = hat(phi);
  return Eigen::Matrix3d::Identity() - b * K + c * K * K;
}

Eigen::Matrix3d right_jacobian_inverse(const Eigen::Vector3d& phi) {
  const double t2 = phi.squaredNorm();
  const double t = std::sqrt(t2);
  double d;  // 1/t^2 - (1 + cos t)/(2 t sin t), written with cot(t/2) so that it stays finite at pi
  if (t < kSmallAngle) {
    d = 1.0 / 12.0 + t2 / 720.0 + t2 * t2 / 30240.0;
  } else {
    d = 1.0 / t2 - std::cos(0.5 * t) / (2.0 * t * std::sin(0.5 * t));
  }
  const Eigen::Matrix3d K = hat(phi);
  return Eigen::Matrix3d::Identity() + 0.5 * K + d * K * K;
}

Eigen::Matrix3d left_jacobian(const Eigen::Vector3d& phi) { return right_jacobian(-phi); }

Eigen::Matrix3d left_jacobian_inverse(const Eigen::Vector3d& phi) {
  return right_jacobian_inverse(-phi);
}

double angle(const Eigen::Quaterniond& q) { return log(q).norm(); }

double angle(const Eigen::Matrix3d& R) { return log(R).norm(); }

}  // namespace ums::so3
