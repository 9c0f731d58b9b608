#include "core/imu/preintegration.hpp"

#include <catch2/catch.hpp>
#include <cmath>
#include <stdexcept>

#include "core/math/so3.hpp"
#include "synthetic_imu.hpp"

namespace {

using Eigen::Vector3d;
using ums::Preintegration;
using ums::Status;
using ums::test::kImuPeriodNs;
using ums::test::SyntheticTrajectory;

// Preintegrates the synthetic trajectory over [t0, t0 + n periods].
void integrate(const SyntheticTrajectory& traj, std::int64_t t0_ns, int n, const Vector3d& ba,
               const Vector3d& bg, Preintegration* pre) {
  REQUIRE(pre->reset(traj.sample(t0_ns), ba, bg) == Status::kOk);
  for (int k = 1; k <= n; ++k)
    REQUIRE(pre->add(traj.sample(t0_ns + k * kImuPeriodNs)) == Status::kOk);
}

}  // namespace

TEST_CASE("preintegration reproduces the deltas of a known trajectory", "[imu][preintegration]") {
  SyntheticTrajectory traj;
  traj.ba = Vector3d(0.05, -0.1, 0.08);
  traj.bg = Vector3d(0.01, -0.02, 0.015);
  Preintegration pre;
  const std::int64_t t0 = 1'000'000'000;
  const int n = 100;  // 0.5 s at 200 Hz
  integrate(traj, t0, n, traj.ba, traj.bg, &pre);
  const double ti = 1.0, tj = 1.5, T = 0.5;
  REQUIRE(std::abs(pre.dt_s() - T) < 1e-12);
  const Eigen::Matrix3d Ri = traj.R(ti);
  const Vector3d alpha_true =
      Ri.transpose() * (traj.p(tj) - traj.p(ti) - traj.v(ti) * T - 0.5 * traj.g_w * T * T);
  const Vector3d beta_true = Ri.transpose() * (traj.v(tj) - traj.v(ti) - traj.g_w * T);
  const Eigen::Matrix3d gamma_true = Ri.transpose() * traj.R(tj);
  // Midpoint rule at 200 Hz on motion of ~1 rad/s and ~1 m/s^2: errors of order dt^2.
  CHECK((pre.alpha() - alpha_true).norm() < 2e-5);  // m
  CHECK((pre.beta() - beta_true).norm() < 1e-4);    // m/s
  CHECK(ums::so3::angle(Eigen::Matrix3d(pre.gamma().toRotationMatrix().transpose() * gamma_true)) <
        2e-5);  // rad
  CHECK(pre.num_samples() == static_cast<std::size_t>(n + 1));
}

TEST_CASE("preintegration covariance of the rotation grows as sigma_g^2 T",
          "[imu][preintegration]") {
  ums::PreintegrationOptions opt;
  Preintegration pre(opt);
  ums::ImuSample s;
  s.accel_m_s2 = Vector3d(0.0, 0.0, 9.81);
  s.t_ns = 0;
  REQUIRE(pre.reset(s, Vector3d::Zero(), Vector3d::Zero()) == Status::kOk);
  for (int k = 1; k <= 200; ++k) {
    s.t_ns = k * kImuPeriodNs;
    REQUIRE(pre.add(s) == Status::kOk);
  }
  const double T = 1.0;
  const double expected_theta = opt.noise.gyro_noise_density * opt.noise.gyro_noise_density * T;
  const double expected_bg = opt.noise.gyro_random_walk * opt.noise.gyro_random_walk * T;
  const double expected_ba = opt.noise.accel_random_walk * opt.noise.accel_random_walk * T;
  for (int k = 0; k < 3; ++k) {
    // The bias random walk adds a little (sigma_bg^2 T^3 / 3), far below 1 %.
    CHECK(std::abs(pre.covariance()(3 + k, 3 + k) / expected_theta - 1.0) < 0.01);
    CHECK(std::abs(pre.covariance()(12 + k, 12 + k) / expected_bg - 1.0) < 1e-9);
    CHECK(std::abs(pre.covariance()(9 + k, 9 + k) / expected_ba - 1.0) < 1e-9);
    // Velocity: accel white noise sigma_a^2 T plus the tilt error times g.
    CHECK(pre.covariance()(6 + k, 6 + k) >
          0.99 * opt.noise.accel_noise_density * opt.noise.accel_noise_density * T);
  }
  CHECK((pre.covariance() - pre.covariance().transpose()).norm() < 1e-15);
  Preintegration::Matrix15 U;
  REQUIRE(pre.sqrt_information(&U) == Status::kOk);
  CHECK((U.transpose() * U * pre.covariance() - Preintegration::Matrix15::Identity()).norm() <
        1e-6);
}

TEST_CASE("preintegration bias Jacobians match central differences of repropagation",
          "[imu][preintegration]") {
  SyntheticTrajectory traj;
  const Vector3d ba0(0.02, -0.03, 0.05), bg0(0.004, 0.002, -0.006);
  Preintegration pre, plus, minus;
  integrate(traj, 2'000'000'000, 100, ba0, bg0, &pre);
  integrate(traj, 2'000'000'000, 100, ba0, bg0, &plus);
  integrate(traj, 2'000'000'000, 100, ba0, bg0, &minus);
  const double h = 1e-6;
  Eigen::Matrix<double, 9, 6> num, ana;
  for (int c = 0; c < 6; ++c) {
    Vector3d dba = Vector3d::Zero(), dbg = Vector3d::Zero();
    (c < 3 ? dba : dbg)(c % 3) = h;
    plus.repropagate(ba0 + dba, bg0 + dbg);
    minus.repropagate(ba0 - dba, bg0 - dbg);
    num.block<3, 1>(0, c) = (plus.alpha() - minus.alpha()) / (2 * h);
    num.block<3, 1>(3, c) =
        ums::so3::log(Eigen::Quaterniond(pre.gamma().conjugate() * plus.gamma())) / (2 * h) -
        ums::so3::log(Eigen::Quaterniond(pre.gamma().conjugate() * minus.gamma())) / (2 * h);
    num.block<3, 1>(6, c) = (plus.beta() - minus.beta()) / (2 * h);
  }
  ana.setZero();
  ana.block<3, 3>(0, 0) = pre.d_alpha_d_ba();
  ana.block<3, 3>(0, 3) = pre.d_alpha_d_bg();
  ana.block<3, 3>(3, 3) = pre.d_gamma_d_bg();
  ana.block<3, 3>(6, 0) = pre.d_beta_d_ba();
  ana.block<3, 3>(6, 3) = pre.d_beta_d_bg();
  INFO("analytic\n" << ana << "\nnumeric\n" << num);
  // The bias Jacobian is the exact derivative of the discrete midpoint scheme.
  CHECK((ana - num).norm() / num.norm() < 1e-6);
}

TEST_CASE("first-order bias correction tracks repropagation to second order",
          "[imu][preintegration]") {
  SyntheticTrajectory traj;
  Preintegration pre, re;
  integrate(traj, 0, 100, Vector3d::Zero(), Vector3d::Zero(), &pre);
  integrate(traj, 0, 100, Vector3d::Zero(), Vector3d::Zero(), &re);
  double err_prev = 0.0;
  for (double s : {0.1, 0.01}) {
    const Vector3d ba = s * Vector3d(0.5, -0.3, 0.2), bg = s * Vector3d(0.05, 0.02, -0.04);
    Vector3d alpha, beta;
    Eigen::Quaterniond gamma;
    pre.corrected(ba, bg, &alpha, &beta, &gamma);
    re.repropagate(ba, bg);
    const double err = (alpha - re.alpha()).norm() + (beta - re.beta()).norm() +
                       ums::so3::angle(Eigen::Quaterniond(gamma.conjugate() * re.gamma()));
    if (err_prev > 0.0) CHECK(err < err_prev / 50.0);  // 10x smaller step -> ~100x smaller error
    err_prev = err;
  }
}

TEST_CASE("preintegration repropagates only beyond the bias thresholds", "[imu][preintegration]") {
  SyntheticTrajectory traj;
  ums::PreintegrationOptions opt;
  Preintegration pre(opt);
  integrate(traj, 0, 50, Vector3d::Zero(), Vector3d::Zero(), &pre);
  CHECK_FALSE(pre.repropagate_if_needed(Vector3d(0.09, 0, 0), Vector3d(0, 0.009, 0)));
  CHECK(pre.repropagations() == 0);
  CHECK(pre.repropagate_if_needed(Vector3d(0, 0, 0), Vector3d(0, 0, 0.011)));
  CHECK(pre.repropagations() == 1);
  CHECK(pre.linearization_bg().z() == 0.011);
  CHECK(pre.repropagate_if_needed(Vector3d(0, -0.11, 0), Vector3d(0, 0, 0.011)));
  CHECK(pre.linearization_ba().y() == -0.11);
}

TEST_CASE("preintegration buffer reports full and bad samples instead of dropping silently",
          "[imu][preintegration]") {
  ums::PreintegrationOptions opt;
  opt.max_samples = 10;
  opt.validate();
  SyntheticTrajectory traj;
  Preintegration pre(opt);
  REQUIRE(pre.reset(traj.sample(0), Vector3d::Zero(), Vector3d::Zero()) == Status::kOk);
  for (int k = 1; k < 10; ++k) REQUIRE(pre.add(traj.sample(k * kImuPeriodNs)) == Status::kOk);
  const Vector3d alpha = pre.alpha();
  CHECK(pre.add(traj.sample(10 * kImuPeriodNs)) == Status::kFull);
  CHECK(pre.num_samples() == 10);
  CHECK(pre.alpha() == alpha);                                             // nothing was integrated
  CHECK(pre.add(traj.sample(9 * kImuPeriodNs)) == Status::kInvalidInput);  // not after the last
  ums::ImuSample bad = traj.sample(11 * kImuPeriodNs);
  bad.gyro_rad_s.x() = std::nan("");
  CHECK(pre.add(bad) == Status::kInvalidInput);
  // The compile-time capacity bounds the runtime option.
  opt.max_samples = ums::capacity::kMaxImuSamplesBetweenFrames + 1;
  CHECK_THROWS_AS(opt.validate(), std::invalid_argument);
  opt.max_samples = 10;
  opt.noise.gyro_noise_density = 0.0;
  CHECK_THROWS_AS(opt.validate(), std::invalid_argument);
  // A single sample has no covariance: the whitening says so.
  Preintegration one;
  REQUIRE(one.reset(traj.sample(0), Vector3d::Zero(), Vector3d::Zero()) == Status::kOk);
  Preintegration::Matrix15 U;
  CHECK(one.sqrt_information(&U) == Status::kSingular);
}

TEST_CASE("interpolate_imu is linear in time", "[imu][preintegration]") {
  ums::ImuSample a, b;
  a.t_ns = 100;
  b.t_ns = 200;
  a.gyro_rad_s = Vector3d(1, 2, 3);
  b.gyro_rad_s = Vector3d(3, 2, 1);
  a.accel_m_s2 = Vector3d(0, 0, 10);
  b.accel_m_s2 = Vector3d(0, 0, 20);
  const ums::ImuSample m = ums::interpolate_imu(a, b, 125);
  CHECK(m.t_ns == 125);
  CHECK((m.gyro_rad_s - Vector3d(1.5, 2, 2.5)).norm() < 1e-15);
  CHECK(std::abs(m.accel_m_s2.z() - 12.5) < 1e-15);
}

// Motion the IMU did not measure widens the factor by exactly its variance: a velocity error of
// 3 sigma of the unmodelled motion (and the position error it makes over the lever arm) whitens
// to about 3, not to hundreds of the IMU's own sigmas;
// and a repropagation (new biases) keeps it, a reset drops it.
TEST_CASE("preintegration: unmodelled motion adds its variance to the deltas, kept until reset", "[imu][preintegration]") {
  const SyntheticTrajectory traj;
  Preintegration pre;
  integrate(traj, 0, 10, Vector3d::Zero(), Vector3d::Zero(), &pre);
  Preintegration::Matrix15 U0, U1;
  REQUIRE(pre.sqrt_information(&U0) == Status::kOk);
  constexpr double kSigmaV = 0.05, kSigmaTheta = 0.01;  // m/s, rad
  pre.add_unmodelled_motion({kSigmaTheta * kSigmaTheta, kSigmaV * kSigmaV, 0.025});
  REQUIRE(pre.has_unmodelled_motion());
  REQUIRE(pre.sqrt_information(&U1) == Status::kOk);
  Eigen::Matrix<double, 15, 1> r = Eigen::Matrix<double, 15, 1>::Zero();
  // The velocity error as the model has it: held for the lever arm, it moved the position too.
  r.segment<3>(Preintegration::kV) = Vector3d(3.0 * kSigmaV, 0.0, 0.0);
  r.segment<3>(Preintegration::kP) = 0.025 * r.segment<3>(Preintegration::kV);
  CHECK((U0 * r).norm() > 100.0);
  CHECK((U1 * r).norm() == Approx(3.0).epsilon(0.02));
  r.setZero();
  r.segment<3>(Preintegration::kTheta) = Vector3d(0.0, 0.0, 2.0 * kSigmaTheta);
  CHECK((U1 * r).norm() == Approx(2.0).epsilon(0.02));
  pre.repropagate(Vector3d(0.05, 0.0, 0.0), Vector3d::Zero());
  CHECK(pre.has_unmodelled_motion());
  REQUIRE(pre.reset(traj.sample(0), Vector3d::Zero(), Vector3d::Zero()) == Status::kOk);
  CHECK_FALSE(pre.has_unmodelled_motion());
}

// Position on its own (a hole that may be a clock jump: the travel the held sample claims): 3 sigma
// of it whitens to about 3, and the velocity keeps the IMU's precision (1 cm/s stays over 10
// sigma: 44.9 before, 22.4 after, the velocity no longer also pinned by the position).
TEST_CASE("preintegration: unmodelled position variance widens the position alone", "[imu][preintegration]") {
  const SyntheticTrajectory traj;
  Preintegration pre;
  integrate(traj, 0, 10, Vector3d::Zero(), Vector3d::Zero(), &pre);
  Preintegration::Matrix15 U0, U1;
  REQUIRE(pre.sqrt_information(&U0) == Status::kOk);
  constexpr double kSigmaP = 0.3;  // m: 0.5 s at 0.6 m/s
  Preintegration::UnmodelledMotion u;
  u.var_p_m2 = kSigmaP * kSigmaP;
  pre.add_unmodelled_motion(u);
  REQUIRE(pre.has_unmodelled_motion());
  REQUIRE(pre.sqrt_information(&U1) == Status::kOk);
  Eigen::Matrix<double, 15, 1> r = Eigen::Matrix<double, 15, 1>::Zero();
  r.segment<3>(Preintegration::kP) = Vector3d(0.0, 3.0 * kSigmaP, 0.0);
  CHECK((U0 * r).norm() > 100.0);
  CHECK((U1 * r).norm() == Approx(3.0).epsilon(0.02));
  r.setZero();
  r.segment<3>(Preintegration::kV) = Vector3d(0.01, 0.0, 0.0);  // m/s
  CHECK((U1 * r).norm() > 10.0);
}
