#include "core/math/se3.hpp"

#include <catch2/catch.hpp>

#include "core/math/so3.hpp"

namespace {
using Eigen::Isometry3d;
using Eigen::Vector3d;
using Vector6d = Eigen::Matrix<double, 6, 1>;

Isometry3d sample_pose(double a) {
  return ums::se3::make(ums::so3::exp_quat(Vector3d(0.3 * a, -0.5, 1.1 * a)),
                        Vector3d(1.0, -2.0 * a, 0.5));
}
}  // namespace

TEST_CASE("se3 compose, inverse and act are consistent", "[math][se3]") {
  const Isometry3d T_a_b = sample_pose(1.0), T_b_c = sample_pose(-0.7);
  const Vector3d p_c(0.4, 0.5, -3.0);
  const Isometry3d T_a_c = ums::se3::compose(T_a_b, T_b_c);
  CHECK((ums::se3::act(T_a_c, p_c) - ums::se3::act(T_a_b, ums::se3::act(T_b_c, p_c))).norm() <
        1e-14);
  const Isometry3d I = ums::se3::compose(T_a_b, ums::se3::inverse(T_a_b));
  CHECK((I.matrix() - Eigen::Matrix4d::Identity()).norm() < 1e-14);
  CHECK((ums::se3::act(T_a_b, p_c) - T_a_b * p_c).norm() < 1e-14);
}

TEST_CASE("se3 exp and log are inverse", "[math][se3]") {
  Vector6d xi;
  xi << 0.5, -1.0, 2.0, 0.4, -0.3, 2.9;
  CHECK((ums::se3::log(ums::se3::exp(xi)) - xi).norm() < 1e-12);
  xi.tail<3>().setZero();  // pure translation
  CHECK((ums::se3::exp(xi).translation() - xi.head<3>()).norm() < 1e-15);
}

TEST_CASE("pose block plus and minus follow the right-perturbation convention", "[math][se3]") {
  double x[7];
  ums::pose_block::from_isometry(sample_pose(0.8), x);
  const double d[6] = {0.1, -0.2, 0.3, 0.02, -0.05, 0.04};
  double y[7];
  ums::pose_block::plus(x, d, y);
  const Isometry3d Tx = ums::pose_block::to_isometry(x), Ty = ums::pose_block::to_isometry(y);
  CHECK((Ty.translation() - Tx.translation() - Vector3d(0.1, -0.2, 0.3)).norm() < 1e-15);
  CHECK((Ty.linear() - Tx.linear() * ums::so3::exp(Vector3d(0.02, -0.05, 0.04))).norm() < 1e-14);
  double back[6];
  ums::pose_block::minus(y, x, back);
  for (int i = 0; i < 6; ++i) CHECK(std::abs(back[i] - d[i]) < 1e-14);
  ums::pose_block::plus(x, d, x);  // aliasing is allowed
  for (int i = 0; i < 7; ++i) CHECK(x[i] == y[i]);
}
