#include "core/estimator/imu_factor.hpp"

#include <catch2/catch.hpp>

#include "core/common/state_layout.hpp"
#include "tests/core/imu/synthetic_imu.hpp"

namespace {

using Eigen::Vector3d;
using ums::test::kImuPeriodNs;
using ums::test::SyntheticTrajectory;

// The true states at the ends of a 50 ms interval (10 samples at 200 Hz, a 20 Hz frame's) of the
// synthetic trajectory, and its preintegration of a gyro whose axes read (1 + scale) too much.
struct Interval {
  double pose_i[7], sb_i[9], pose_j[7], sb_j[9];
  ums::Preintegration pre;
  ums::ImuFactor factor;

  Interval(const SyntheticTrajectory& traj, const Vector3d& scale) {
    const std::int64_t t0_ns = 2'000'000'000, n = 10;
    auto write = [&](double t_s, double* pose, double* sb) {
      Eigen::Map<Vector3d> p(pose), v(sb), ba(sb + ums::state::kSbBa), bg(sb + ums::state::kSbBg);
      Eigen::Map<Eigen::Quaterniond> q(pose + 3);
      p = traj.p(t_s);
      q = traj.q(t_s);
      v = traj.v(t_s);
      ba = traj.ba;
      bg = traj.bg;
    };
    write(1e-9 * static_cast<double>(t0_ns), pose_i, sb_i);
    write(1e-9 * static_cast<double>(t0_ns + n * kImuPeriodNs), pose_j, sb_j);
    auto measured = [&](std::int64_t t_ns) {
      ums::ImuSample s = traj.sample(t_ns);
      s.gyro_rad_s = (s.gyro_rad_s - traj.bg).cwiseProduct(Vector3d::Ones() + scale) + traj.bg;
      return s;
    };
    REQUIRE(pre.reset(measured(t0_ns), traj.ba, traj.bg) == ums::Status::kOk);
    for (int k = 1; k <= n; ++k) REQUIRE(pre.add(measured(t0_ns + k * kImuPeriodNs)) == ums::Status::kOk);
    REQUIRE(factor.residual().init(&pre, traj.g_w) == ums::Status::kOk);
  }

  Eigen::Matrix<double, 15, 1> residual(const double* scale, double* jac_scale = nullptr) {
    const double* x[5] = {pose_i, sb_i, pose_j, sb_j, scale};
    Eigen::Matrix<double, 15, 1> r;
    ums::solver::JacobianView views[5];
    if (jac_scale != nullptr) views[4] = ums::solver::JacobianView{jac_scale, 3};
    REQUIRE(factor.evaluate(x, r.data(), jac_scale != nullptr ? views : nullptr));
    return r;
  }
};

}  // namespace

TEST_CASE("ImuFactor: a gyro scale error is taken out by the scale block, to first order", "[estimator][imu]") {
  SyntheticTrajectory traj;
  traj.bg = Vector3d(0.003, -0.002, 0.004);
  const Vector3d s_true(0.005, -0.004, 0.003);  // +-0.5 %: a MEMS gyro's
  Interval with_error(traj, s_true);
  Interval ideal(traj, Vector3d::Zero());
  with_error.factor.set_gyro_scale(true);
  ideal.factor.set_gyro_scale(true);
  const double zero[3] = {0.0, 0.0, 0.0};
  const double truth[3] = {s_true.x(), s_true.y(), s_true.z()};
  // Whitened (default noise): 0.91 at zero scale, 0.022 at the true one, within 0.016 of the ideal
  // gyro's; what is left is the first-order model's remainder (the rate changes in 50 ms).
  const double at_zero = with_error.residual(zero).norm();
  const double at_truth = with_error.residual(truth).norm();
  const double ideal_norm = ideal.residual(zero).norm();
  INFO("whitened residual: " << at_zero << " at zero scale, " << at_truth << " at the true one, " << ideal_norm
                             << " ideal");
  CHECK(at_zero > 20.0 * std::max(at_truth, 1e-3));
  CHECK(std::abs(at_truth - ideal_norm) < 0.05 * at_zero);
}

TEST_CASE("ImuFactor: the scale block's Jacobian matches numeric differences", "[estimator][imu]") {
  SyntheticTrajectory traj;
  traj.bg = Vector3d(0.003, -0.002, 0.004);
  Interval iv(traj, Vector3d(0.005, -0.004, 0.003));
  iv.factor.set_gyro_scale(true);
  const double s0[3] = {0.002, -0.001, 0.004};
  Eigen::Matrix<double, 15, 3, Eigen::RowMajor> analytic;
  iv.residual(s0, analytic.data());
  Eigen::Matrix<double, 15, 3> numeric;
  const double h = 1e-6;
  for (int c = 0; c < 3; ++c) {
    double plus[3] = {s0[0], s0[1], s0[2]}, minus[3] = {s0[0], s0[1], s0[2]};
    plus[c] += h;
    minus[c] -= h;
    numeric.col(c) = (iv.residual(plus) - iv.residual(minus)) / (2.0 * h);
  }
  INFO("analytic\n" << analytic << "\nnumeric\n" << numeric);
  CHECK((Eigen::Matrix<double, 15, 3>(analytic) - numeric).norm() < 1e-6 * numeric.norm());
  // Without the block the factor is the plain residual: the same numbers, bit for bit.
  iv.factor.set_gyro_scale(false);
  const double* x4[4] = {iv.pose_i, iv.sb_i, iv.pose_j, iv.sb_j};
  Eigen::Matrix<double, 15, 1> r4, r_plain;
  REQUIRE(iv.factor.evaluate(x4, r4.data(), nullptr));
  REQUIRE(iv.factor.residual().evaluate(iv.pose_i, iv.sb_i, iv.pose_j, iv.sb_j, r_plain.data(), nullptr, nullptr,
                                        nullptr, nullptr));
  CHECK(r4 == r_plain);
}
