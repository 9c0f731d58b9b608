#include "core/math/quaternion.hpp"

#include <catch2/catch.hpp>
#include <cmath>

#include "core/math/so3.hpp"

namespace {
using Eigen::Quaterniond;
using Eigen::Vector3d;
namespace quat = ums::quat;
}  // namespace

TEST_CASE("quaternion product matrices reproduce the Hamilton product", "[math][quat]") {
  const Quaterniond p = ums::so3::exp_quat(Vector3d(0.3, -0.8, 1.1));
  const Quaterniond q = ums::so3::exp_quat(Vector3d(-1.4, 0.2, 0.6));
  const Eigen::Vector4d pq = quat::to_wxyz(p * q);
  CHECK((quat::left(p) * quat::to_wxyz(q) - pq).norm() < 1e-15);
  CHECK((quat::right(q) * quat::to_wxyz(p) - pq).norm() < 1e-15);
  // Hamilton: the product composes rotations like matrices do.
  CHECK(((p * q).toRotationMatrix() - p.toRotationMatrix() * q.toRotationMatrix()).norm() < 1e-14);
  CHECK((quat::from_wxyz(quat::to_wxyz(p)).coeffs() - p.coeffs()).norm() == 0.0);
}

TEST_CASE("quaternion normalisation keeps w non-negative", "[math][quat]") {
  const Quaterniond q(-2.0, 0.4, -0.2, 1.0);
  const Quaterniond n = quat::normalized_positive(q);
  CHECK(std::abs(n.norm() - 1.0) < 1e-15);
  CHECK(n.w() > 0.0);
  CHECK((n.toRotationMatrix() - q.normalized().toRotationMatrix()).norm() < 1e-14);
  CHECK(quat::normalized_positive(Quaterniond(0, 0, 0, 0)).w() == 1.0);
}

TEST_CASE("small-angle quaternion agrees with exp to second order", "[math][quat]") {
  for (double t : {1e-2, 1e-3, 1e-4}) {
    const Vector3d d = t * Vector3d(0.6, -0.8, 0.0);
    const double err = ums::so3::angle(quat::small_angle(d).conjugate() * ums::so3::exp_quat(d));
    CHECK(err < t * t * t);  // the error is third order in the angle
  }
}

TEST_CASE("remove_yaw keeps roll and pitch and zeroes yaw", "[math][quat]") {
  const Eigen::Matrix3d R =
      (Eigen::AngleAxisd(1.2, Vector3d::UnitZ()) * Eigen::AngleAxisd(0.3, Vector3d::UnitY()) *
       Eigen::AngleAxisd(-0.2, Vector3d::UnitX()))
          .toRotationMatrix();
  CHECK(std::abs(quat::yaw(R) - 1.2) < 1e-14);
  const Eigen::Matrix3d R0 = quat::remove_yaw(R);
  CHECK(std::abs(quat::yaw(R0)) < 1e-14);
  // Gravity seen in the body is unchanged (roll and pitch kept).
  CHECK((R0.transpose() * Vector3d::UnitZ() - R.transpose() * Vector3d::UnitZ()).norm() < 1e-14);
}

TEST_CASE("wrap_angle_rad maps any angle into -pi < a <= pi without changing its direction", "[math][quat]") {
  CHECK(quat::wrap_angle_rad(0.25) == 0.25);
  CHECK(std::abs(quat::wrap_angle_rad(0.25 + 6.0 * M_PI) - 0.25) < 1e-12);
  CHECK(std::abs(quat::wrap_angle_rad(-3.0 * M_PI / 2.0) - M_PI / 2.0) < 1e-12);
  CHECK(quat::wrap_angle_rad(-M_PI) == M_PI);  // the half-open end
  CHECK(quat::wrap_angle_rad(M_PI) == M_PI);
}
