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

TEST_CASE("pose prior: zero at the target, metres and radians over sigma, Jacobians", "[estimator]") {
  ums::PosePrior prior;
  const Eigen::Quaterniond q0(Eigen::AngleAxisd(0.7, Eigen::Vector3d(0, 1, 1).normalized()));
  prior.set(Eigen::Vector3d(0.1, -0.02, 0.03), q0, 0.01, 0.02);
  double x[7] = {0.1, -0.02, 0.03, q0.x(), q0.y(), q0.z(), q0.w()};
  const double* p[] = {x};
  double r[6];
  REQUIRE(prior.evaluate(p, r, nullptr));
  for (double v : r) CHECK(std::abs(v) < 1e-12);
  x[1] += 0.02;  // 2 cm = two sigma
  const Eigen::Quaterniond q = q0 * Eigen::Quaterniond(Eigen::AngleAxisd(0.01, Eigen::Vector3d::UnitX()));
  x[3] = q.x(); x[4] = q.y(); x[5] = q.z(); x[6] = q.w();
  REQUIRE(prior.evaluate(p, r, nullptr));
  CHECK(r[1] == Approx(2.0));
  CHECK(r[3] == Approx(0.5).epsilon(1e-6));  // 0.01 rad about the body x axis over 0.02
  CHECK(ums::test::max_jacobian_error(prior, {{x, 7, true}}) < 1e-6);
}

TEST_CASE("relative pose prior: zero at the calibrated relative pose, in a's frame, Jacobians", "[estimator]") {
  ums::RelativePosePrior prior;
  const Eigen::Quaterniond q_ab(Eigen::AngleAxisd(0.02, Eigen::Vector3d(1, 0, 1).normalized()));
  const Eigen::Vector3d t_ab(0.095, 0.001, -0.002);
  prior.set(t_ab, q_ab, 0.0005, 0.001);
  const Eigen::Quaterniond q_a(Eigen::AngleAxisd(1.2, Eigen::Vector3d(1, 2, 3).normalized()));
  const Eigen::Vector3d p_a(0.05, -0.01, 0.02);
  const Eigen::Quaterniond q_b = q_a * q_ab;
  const Eigen::Vector3d p_b = p_a + q_a * t_ab;
  double a[7] = {p_a.x(), p_a.y(), p_a.z(), q_a.x(), q_a.y(), q_a.z(), q_a.w()};
  double b[7] = {p_b.x(), p_b.y(), p_b.z(), q_b.x(), q_b.y(), q_b.z(), q_b.w()};
  const double* p[] = {a, b};
  double r[6];
  REQUIRE(prior.evaluate(p, r, nullptr));
  for (double v : r) CHECK(std::abs(v) < 1e-9);
  // Both moved alike (the rig against the IMU): still zero.
  const Eigen::Quaterniond dq(Eigen::AngleAxisd(0.3, Eigen::Vector3d::UnitZ()));
  const Eigen::Vector3d dp(0.01, 0.02, -0.03);
  const Eigen::Quaterniond qa2 = dq * q_a, qb2 = dq * q_b;
  const Eigen::Vector3d pa2 = dq * p_a + dp, pb2 = dq * p_b + dp;
  double a2[7] = {pa2.x(), pa2.y(), pa2.z(), qa2.x(), qa2.y(), qa2.z(), qa2.w()};
  double b2[7] = {pb2.x(), pb2.y(), pb2.z(), qb2.x(), qb2.y(), qb2.z(), qb2.w()};
  const double* p2[] = {a2, b2};
  REQUIRE(prior.evaluate(p2, r, nullptr));
  for (double v : r) CHECK(std::abs(v) < 1e-9);
  b2[0] += 0.001;  // the baseline changed: 1 mm along a's rotated axes
  REQUIRE(prior.evaluate(p2, r, nullptr));
  CHECK(Eigen::Vector3d(r[0], r[1], r[2]).norm() == Approx(2.0).epsilon(1e-9));
  CHECK(ums::test::max_jacobian_error(prior, {{a2, 7, true}, {b2, 7, true}}) < 1e-6);
}
