#include "solver/manifold.hpp"

#include <catch2/catch.hpp>

namespace ums::solver {
namespace {

TEST_CASE("SO(3) exp and log are inverse, also near zero and near pi", "[solver][manifold]") {
  const Eigen::Vector3d cases[] = {{0.3, -0.2, 0.1}, {1e-9, 2e-9, -1e-9}, {0.0, 0.0, 3.1},
                                   {1e-5, 0.0, 0.0}};
  for (const auto& theta : cases) {
    const Eigen::Vector3d back = so3_log(so3_exp(theta));
    CHECK((back - theta).norm() <= 1e-12 * (1.0 + theta.norm()));
    CHECK(std::abs(so3_exp(theta).norm() - 1.0) < 1e-15);
  }
}

TEST_CASE("Pose plus/minus follow the right-perturbation convention", "[solver][manifold]") {
  const Eigen::Quaterniond q(Eigen::AngleAxisd(0.7, Eigen::Vector3d(1, 2, 3).normalized()));
  const double x[7] = {1.0, 2.0, 3.0, q.x(), q.y(), q.z(), q.w()};
  const double d[6] = {0.1, -0.2, 0.3, 0.02, -0.01, 0.03};
  double y[7];
  manifold_plus(ManifoldType::kPose, 7, x, d, y);
  // q_y = q * Exp(dtheta): the rotation increment acts in the body frame.
  const Eigen::Quaterniond q_expected = q * so3_exp(Eigen::Vector3d(0.02, -0.01, 0.03));
  CHECK(Eigen::Map<const Eigen::Quaterniond>(y + 3).angularDistance(q_expected) < 1e-14);
  CHECK(y[0] == Approx(1.1).margin(1e-15));
  double back[6];
  manifold_minus(ManifoldType::kPose, 7, y, x, back);
  for (int i = 0; i < 6; ++i) CHECK(back[i] == Approx(d[i]).margin(1e-13));
}

TEST_CASE("Right Jacobian and its inverse match finite differences", "[solver][manifold]") {
  const Eigen::Vector3d phi(0.4, -0.3, 0.8);
  const Eigen::Matrix3d Jr = so3_right_jacobian(phi);
  const Eigen::Matrix3d Jr_inv = so3_right_jacobian_inverse(phi);
  CHECK((Jr * Jr_inv - Eigen::Matrix3d::Identity()).norm() < 1e-12);
  const double h = 1e-6;
  for (int k = 0; k < 3; ++k) {
    const Eigen::Vector3d e = Eigen::Vector3d::Unit(k) * h;
    // Log(Exp(phi) Exp(e)) - phi ~ Jr^-1 e
    const Eigen::Vector3d num =
        (so3_log(so3_exp(phi) * so3_exp(e)) - so3_log(so3_exp(phi) * so3_exp(-e))) / (2.0 * h);
    CHECK((num - Jr_inv.col(k)).norm() < 1e-8);
  }
}

}  // namespace
}  // namespace ums::solver
