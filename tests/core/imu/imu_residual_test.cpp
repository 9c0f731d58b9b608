#include "core/imu/imu_residual.hpp"

#include <algorithm>
#include <catch2/catch.hpp>
#include <cmath>
#include <cstdio>
#include <random>

#include "core/imu/propagation.hpp"
#include "core/math/se3.hpp"
#include "core/math/so3.hpp"
#include "profiling/alloc_counter.hpp"
#include "synthetic_imu.hpp"

namespace {

using Eigen::Vector3d;
using ums::ImuResidual;
using ums::Preintegration;
using ums::Status;
using ums::test::kImuPeriodNs;
using ums::test::SyntheticTrajectory;

struct Blocks {
  double pose_i[7], sb_i[9], pose_j[7], sb_j[9];
};

void write(const Vector3d& p, const Eigen::Quaterniond& q, const Vector3d& v, const Vector3d& ba,
           const Vector3d& bg, double* pose, double* sb) {
  Eigen::Map<Vector3d> pm(pose), vm(sb), bam(sb + 3), bgm(sb + 6);
  Eigen::Map<Eigen::Quaterniond> qm(pose + 3);
  pm = p;
  qm = q;
  vm = v;
  bam = ba;
  bgm = bg;
}

// The true states of the synthetic trajectory at ti and tj.
Blocks truth(const SyntheticTrajectory& traj, double ti, double tj) {
  Blocks b;
  write(traj.p(ti), traj.q(ti), traj.v(ti), traj.ba, traj.bg, b.pose_i, b.sb_i);
  write(traj.p(tj), traj.q(tj), traj.v(tj), traj.ba, traj.bg, b.pose_j, b.sb_j);
  return b;
}

void preintegrate(const SyntheticTrajectory& traj, std::int64_t t0_ns, int n, const Vector3d& ba,
                  const Vector3d& bg, Preintegration* pre) {
  REQUIRE(pre->reset(traj.sample(t0_ns), ba, bg) == Status::kOk);
  for (int k = 1; k <= n; ++k)
    REQUIRE(pre->add(traj.sample(t0_ns + k * kImuPeriodNs)) == Status::kOk);
}

// Relative Frobenius error of an analytic Jacobian against central differences through the
// manifold plus of each block.
template <int kTangent, typename Apply>
double jacobian_error(const Eigen::Matrix<double, 15, kTangent, Eigen::RowMajor>& analytic,
                      Apply&& residual_at) {
  const double h = 1e-6;
  Eigen::Matrix<double, 15, kTangent> numeric;
  for (int c = 0; c < kTangent; ++c) {
    Eigen::Matrix<double, kTangent, 1> d = Eigen::Matrix<double, kTangent, 1>::Zero();
    d(c) = h;
    numeric.col(c) = (residual_at(d) - residual_at(-d)) / (2.0 * h);
  }
  INFO("analytic\n" << analytic << "\nnumeric\n" << numeric);
  const double err =
      (Eigen::Matrix<double, 15, kTangent>(analytic) - numeric).norm() / numeric.norm();
  CHECK(err < 1e-6);
  return err;
}

}  // namespace

TEST_CASE("imu residual is zero at the true states", "[imu][residual]") {
  SyntheticTrajectory traj;
  traj.ba = Vector3d(0.1, -0.05, 0.02);
  traj.bg = Vector3d(0.003, -0.002, 0.004);
  Preintegration pre;
  preintegrate(traj, 3'000'000'000, 100, traj.ba, traj.bg, &pre);
  ImuResidual res;
  REQUIRE(res.init(&pre, traj.g_w) == Status::kOk);
  const Blocks b = truth(traj, 3.0, 3.5);
  const ImuResidual::Vector15 r = res.raw_residual(b.pose_i, b.sb_i, b.pose_j, b.sb_j);
  CHECK(r.segment<3>(0).norm() < 2e-5);  // m
  CHECK(r.segment<3>(3).norm() < 4e-5);  // rad (2 vec q ~ angle)
  CHECK(r.segment<3>(6).norm() < 1e-4);  // m/s
  CHECK(r.segment<6>(9).norm() == 0.0);
  // Whitened: |r_w|^2 is the Mahalanobis norm r^T P^-1 r.
  ImuResidual::Vector15 rw;
  REQUIRE(res.evaluate(b.pose_i, b.sb_i, b.pose_j, b.sb_j, rw.data(), nullptr, nullptr, nullptr,
                       nullptr));
  const double maha = r.dot(pre.covariance().ldlt().solve(r));
  CHECK(std::abs(rw.squaredNorm() - maha) < 1e-6 * maha);
}

TEST_CASE("imu residual whitening follows the preintegration: kept while unchanged, renewed after",
          "[imu][residual]") {
  SyntheticTrajectory traj;
  Preintegration pre;
  preintegrate(traj, 2'000'000'000, 80, traj.ba, traj.bg, &pre);
  ImuResidual res;
  const auto matches = [&](const Preintegration& p) {
    Preintegration::Matrix15 U;
    REQUIRE(p.sqrt_information(&U) == Status::kOk);
    return res.sqrt_information() == U;  // bit for bit
  };
  REQUIRE(res.init(&pre, traj.g_w) == Status::kOk);
  CHECK(matches(pre));
  const Preintegration::Matrix15 U0 = res.sqrt_information();
  // Re-bound unchanged (what the window does every frame): the same factor.
  REQUIRE(res.init(&pre, traj.g_w) == Status::kOk);
  CHECK(res.sqrt_information() == U0);
  // More samples: a new covariance, a new factor.
  REQUIRE(pre.add(traj.sample(2'000'000'000 + 81 * kImuPeriodNs)) == Status::kOk);
  REQUIRE(res.update_whitening() == Status::kOk);
  CHECK(matches(pre));
  CHECK_FALSE(res.sqrt_information() == U0);
  // Unmodelled motion changes the whitened covariance, not covariance(): renewed as well.
  const Preintegration::Matrix15 U1 = res.sqrt_information();
  Preintegration::UnmodelledMotion u;
  u.var_theta_rad2 = 1e-4;
  pre.add_unmodelled_motion(u);
  REQUIRE(res.update_whitening() == Status::kOk);
  CHECK(matches(pre));
  CHECK(res.sqrt_information()(0, 0) != U1(0, 0));
  // A singular covariance is refused every time; the next valid one is whitened afresh.
  Preintegration one;
  REQUIRE(one.reset(traj.sample(5'000'000'000), traj.ba, traj.bg) == Status::kOk);
  CHECK(res.init(&one, traj.g_w) == Status::kSingular);
  CHECK(res.init(&one, traj.g_w) == Status::kSingular);
  REQUIRE(res.init(&pre, traj.g_w) == Status::kOk);
  CHECK(matches(pre));
}

TEST_CASE("imu residual Jacobians match central differences through the manifold plus",
          "[imu][residual]") {
  std::mt19937 rng(42);
  std::normal_distribution<double> n01(0.0, 1.0);
  auto rv = [&](double s) { return Vector3d(s * n01(rng), s * n01(rng), s * n01(rng)); };
  SyntheticTrajectory traj;
  double worst = 0.0;
  for (int trial = 0; trial < 5; ++trial) {
    Preintegration pre;
    const Vector3d ba_lin = rv(0.05), bg_lin = rv(0.005);
    preintegrate(traj, 1'000'000'000LL * trial, 60 + 20 * trial, ba_lin, bg_lin, &pre);
    ImuResidual res;
    REQUIRE(res.init(&pre, traj.g_w) == Status::kOk);
    // States away from the truth, biases away from the linearisation point (the correction
    // terms and the Jr of the gamma correction are exercised).
    Blocks b;
    const double ti = 1.0 * trial, tj = ti + pre.dt_s();
    write(traj.p(ti) + rv(0.3), traj.q(ti) * ums::so3::exp_quat(rv(0.2)), traj.v(ti) + rv(0.3),
          ba_lin + rv(0.05), bg_lin + rv(0.01), b.pose_i, b.sb_i);
    write(traj.p(tj) + rv(0.3), traj.q(tj) * ums::so3::exp_quat(rv(0.2)), traj.v(tj) + rv(0.3),
          ba_lin + rv(0.05), bg_lin + rv(0.01), b.pose_j, b.sb_j);
    ImuResidual::JacobianPose J_pi, J_pj;
    ImuResidual::JacobianSpeedBias J_si, J_sj;
    ImuResidual::Vector15 r;
    REQUIRE(res.evaluate(b.pose_i, b.sb_i, b.pose_j, b.sb_j, r.data(), J_pi.data(), J_si.data(),
                         J_pj.data(), J_sj.data()));
    INFO("trial " << trial);

    auto eval = [&](const Blocks& x) {
      ImuResidual::Vector15 out;
      res.evaluate(x.pose_i, x.sb_i, x.pose_j, x.sb_j, out.data(), nullptr, nullptr, nullptr,
                   nullptr);
      return out;
    };
    worst = std::max(worst, jacobian_error<6>(J_pi, [&](const Eigen::Matrix<double, 6, 1>& d) {
                       Blocks x = b;
                       ums::pose_block::plus(b.pose_i, d.data(), x.pose_i);
                       return eval(x);
                     }));
    worst = std::max(worst, jacobian_error<6>(J_pj, [&](const Eigen::Matrix<double, 6, 1>& d) {
                       Blocks x = b;
                       ums::pose_block::plus(b.pose_j, d.data(), x.pose_j);
                       return eval(x);
                     }));
    worst = std::max(worst, jacobian_error<9>(J_si, [&](const Eigen::Matrix<double, 9, 1>& d) {
                       Blocks x = b;
                       for (int k = 0; k < 9; ++k) x.sb_i[k] += d(k);
                       return eval(x);
                     }));
    worst = std::max(worst, jacobian_error<9>(J_sj, [&](const Eigen::Matrix<double, 9, 1>& d) {
                       Blocks x = b;
                       for (int k = 0; k < 9; ++k) x.sb_j[k] += d(k);
                       return eval(x);
                     }));
  }
  std::printf("imu residual: worst relative Jacobian error vs central differences %.2e\n", worst);
}

TEST_CASE("a full preintegrate and evaluate cycle allocates nothing", "[imu][residual][alloc]") {
  SyntheticTrajectory traj;
  // Samples and blocks prepared outside the measured scope.
  static ums::ImuSample samples[101];
  for (int k = 0; k <= 100; ++k) samples[k] = traj.sample(k * kImuPeriodNs);
  const Blocks b = truth(traj, 0.0, 0.5);
  static Preintegration pre;
  ImuResidual res;
  ImuResidual::JacobianPose J_pi, J_pj;
  ImuResidual::JacobianSpeedBias J_si, J_sj;
  ImuResidual::Vector15 r;

  ums::AllocScope scope;
  for (int cycle = 0; cycle < 3; ++cycle) {
    REQUIRE(pre.reset(samples[0], traj.ba, traj.bg) == Status::kOk);
    for (int k = 1; k <= 100; ++k) REQUIRE(pre.add(samples[k]) == Status::kOk);
    pre.repropagate(traj.ba + Vector3d::Constant(0.2), traj.bg);
    REQUIRE(res.init(&pre, traj.g_w) == Status::kOk);
    REQUIRE(res.evaluate(b.pose_i, b.sb_i, b.pose_j, b.sb_j, r.data(), J_pi.data(), J_si.data(),
                         J_pj.data(), J_sj.data()));
    const ums::NavState predicted = ums::predict(ums::NavState(), pre, traj.g_w);
    REQUIRE(predicted.t_ns == samples[100].t_ns);
  }
  if (ums::alloc_counter_available()) {
    std::printf("imu preintegrate+evaluate: %llu allocations in 3 cycles\n",
                static_cast<unsigned long long>(scope.allocations()));
    CHECK(scope.allocations() == 0);
  } else {
    WARN("allocation hooks not available in this build (sanitizer); not measured");
  }
}
