#include "core/math/so3.hpp"

#include <catch2/catch.hpp>
#include <cmath>
#include <random>

namespace {

using Eigen::Matrix3d;
using Eigen::Vector3d;
namespace so3 = ums::so3;

constexpr double kPi = 3.14159265358979323846;

Vector3d random_unit(std::mt19937& rng) {
  std::normal_distribution<double> n(0.0, 1.0);
  return Vector3d(n(rng), n(rng), n(rng)).normalized();
}

// Rotation vectors that exercise every branch: random, tiny, small-series boundary, near pi.
std::vector<Vector3d> test_angles() {
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> u(0.0, kPi);
  std::vector<Vector3d> v;
  for (int i = 0; i < 20; ++i) v.push_back(u(rng) * random_unit(rng));
  for (double t : {0.0, 1e-12, 1e-8, 1e-6, 0.999e-5, 1.001e-5, 0.999e-2, 1.001e-2, 0.5, 2.0,
                   kPi - 1e-3, kPi - 1e-6, kPi - 1e-9}) {
    v.push_back(t * random_unit(rng));
  }
  return v;
}

}  // namespace

TEST_CASE("so3 hat and vee are inverse and hat is the cross product", "[math][so3]") {
  const Vector3d a(0.3, -1.2, 2.5), b(-0.7, 0.1, 0.4);
  CHECK((so3::hat(a) * b - a.cross(b)).norm() < 1e-15);
  CHECK((so3::vee(so3::hat(a)) - a).norm() < 1e-15);
  CHECK((so3::hat(a) + so3::hat(a).transpose()).norm() == 0.0);
}

TEST_CASE("so3 exp matches Eigen AngleAxis and exp_quat at all angles", "[math][so3]") {
  for (const Vector3d& phi : test_angles()) {
    const double t = phi.norm();
    const Matrix3d R_ref =
        t > 0.0 ? Eigen::AngleAxisd(t, phi / t).toRotationMatrix() : Matrix3d::Identity();
    const Matrix3d R = so3::exp(phi);
    CHECK((R - R_ref).norm() < 1e-14);
    CHECK((R * R.transpose() - Matrix3d::Identity()).norm() < 1e-14);
    CHECK((so3::exp_quat(phi).toRotationMatrix() - R_ref).norm() < 1e-14);
    CHECK(std::abs(so3::exp_quat(phi).norm() - 1.0) < 1e-15);
  }
}

TEST_CASE("so3 log inverts exp, including near zero and near pi", "[math][so3]") {
  for (const Vector3d& phi : test_angles()) {
    const Vector3d back = so3::log(so3::exp(phi));
    const Vector3d back_q = so3::log(so3::exp_quat(phi));
    INFO("angle " << phi.norm());
    // Relative to the angle (absolute 1e-15 floor); near pi the axis is still recovered to ~1e-8.
    const double tol = phi.norm() > kPi - 1e-5 ? 1e-7 : 1e-13 * std::max(1.0, phi.norm());
    CHECK((back - phi).norm() <= tol + 1e-15);
    CHECK((back_q - phi).norm() <= 1e-13 * std::max(1.0, phi.norm()) + 1e-15);
    if (phi.norm() > 0.0 && phi.norm() < 1e-5) {
      CHECK((back - phi).norm() / phi.norm() < 1e-9);  // tiny angles keep relative precision
    }
  }
  // Exactly pi: log returns an angle of pi about the right axis (either sign).
  const Vector3d axis = Vector3d(1.0, 2.0, -0.5).normalized();
  const Vector3d phi_pi = so3::log(so3::exp(kPi * axis));
  CHECK(std::abs(phi_pi.norm() - kPi) < 1e-8);
  CHECK(std::abs(std::abs(phi_pi.normalized().dot(axis)) - 1.0) < 1e-12);
  // q and -q are the same rotation.
  const Eigen::Quaterniond q = so3::exp_quat(Vector3d(0.2, -0.4, 1.0));
  Eigen::Quaterniond mq = q;
  mq.coeffs() = -mq.coeffs();
  CHECK((so3::log(q) - so3::log(mq)).norm() < 1e-15);
  CHECK(std::abs(so3::angle(q) - Vector3d(0.2, -0.4, 1.0).norm()) < 1e-14);
}

TEST_CASE("so3 right and left Jacobians match central differences", "[math][so3]") {
  const double h = 1e-6;
  for (const Vector3d& phi : test_angles()) {
    if (phi.norm() > kPi - 1e-2) continue;  // log() wraps within h of pi: checked separately
    const Matrix3d R = so3::exp(phi);
    Matrix3d Jr_num, Jl_num;
    for (int k = 0; k < 3; ++k) {
      const Vector3d e = h * Vector3d::Unit(k);
      Jr_num.col(k) = (so3::log(R.transpose() * so3::exp(phi + e)) -
                       so3::log(R.transpose() * so3::exp(phi - e))) /
                      (2.0 * h);
      Jl_num.col(k) = (so3::log(so3::exp(phi + e) * R.transpose()) -
                       so3::log(so3::exp(phi - e) * R.transpose())) /
                      (2.0 * h);
    }
    INFO("angle " << phi.norm());
    CHECK((so3::right_jacobian(phi) - Jr_num).norm() < 1e-8);
    CHECK((so3::left_jacobian(phi) - Jl_num).norm() < 1e-8);
  }
}

TEST_CASE("so3 Jacobian inverses are inverses up to pi", "[math][so3]") {
  for (const Vector3d& phi : test_angles()) {
    INFO("angle " << phi.norm());
    const Matrix3d I = Matrix3d::Identity();
    CHECK((so3::right_jacobian(phi) * so3::right_jacobian_inverse(phi) - I).norm() < 1e-11);
    CHECK((so3::left_jacobian(phi) * so3::left_jacobian_inverse(phi) - I).norm() < 1e-11);
    // Jl(phi) = R Jr(phi): a property that ties both to exp().
    CHECK((so3::left_jacobian(phi) - so3::exp(phi) * so3::right_jacobian(phi)).norm() < 1e-13);
  }
}
