#include "core/estimator/state_residuals.hpp"

#include <catch2/catch.hpp>

#include <Eigen/Geometry>

#include "tests/core/estimator/jacobian_check.hpp"

TEST_CASE("speed-bias prior: whitened by sigma, free rows are zero", "[estimator]") {
  ums::SpeedBiasPrior prior;
  ums::SpeedBiasPrior::Vector9 target = ums::SpeedBiasPrior::Vector9::Zero();
  ums::SpeedBiasPrior::Vector9 sigma;
  sigma << 0.0, 0.0, 0.0, 0.2, 0.2, 0.2, 0.02, 0.02, 0.02;
  prior.set(target, sigma);
  double sb[9] = {1.0, 2.0, 3.0, 0.1, 0.0, 0.0, 0.0, 0.01, 0.0};
  const double* p[] = {sb};
  double r[9];
  REQUIRE(prior.evaluate(p, r, nullptr));
  CHECK(r[0] == 0.0);  // velocity left free
  CHECK(r[3] == Approx(0.5));
  CHECK(r[7] == Approx(0.5));
  CHECK(ums::test::max_jacobian_error(prior, {{sb, 9, false}}) < 1e-8);
}

TEST_CASE("still residual: zero for equal poses, metres and radians over sigma otherwise, Jacobians", "[estimator]") {
  ums::StillResidual still;
  still.set(0.002, 0.001);
  double a[7] = {1.0, 2.0, 3.0, 0.0, 0.0, 0.0, 1.0};
  const Eigen::Quaterniond q(Eigen::AngleAxisd(0.4, Eigen::Vector3d(1, 1, 0).normalized()));
  a[3] = q.x(); a[4] = q.y(); a[5] = q.z(); a[6] = q.w();
  double b[7];
  std::copy(a, a + 7, b);
  const double* p[] = {a, b};
  double r[6];
  REQUIRE(still.evaluate(p, r, nullptr));
  for (double v : r) CHECK(std::abs(v) < 1e-12);
  b[0] += 0.002;  // 2 mm = one sigma
  const Eigen::Quaterniond qb = q * Eigen::Quaterniond(Eigen::AngleAxisd(0.003, Eigen::Vector3d::UnitZ()));
  b[3] = qb.x(); b[4] = qb.y(); b[5] = qb.z(); b[6] = qb.w();
  REQUIRE(still.evaluate(p, r, nullptr));
  CHECK(r[0] == Approx(1.0));
  CHECK(r[5] == Approx(3.0).epsilon(1e-6));
  CHECK(ums::test::max_jacobian_error(still, {{a, 7, true}, {b, 7, true}}) < 1e-6);
}
