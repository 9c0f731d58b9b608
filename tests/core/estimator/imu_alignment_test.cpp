#include "core/estimator/imu_alignment.hpp"

#include <catch2/catch.hpp>

#include "core/math/so3.hpp"

namespace {

// Analytic motion: R = Rz(a(t)) Ry(b(t)), p = smooth curve; IMU from its derivatives.
struct Motion {
  static double a(double t) { return 0.6 * std::sin(0.9 * t); }
  static double da(double t) { return 0.54 * std::cos(0.9 * t); }
  static double b(double t) { return 0.3 * std::sin(1.3 * t + 0.4); }
  static double db(double t) { return 0.39 * std::cos(1.3 * t + 0.4); }
  static Eigen::Matrix3d R(double t) {
    return (Eigen::AngleAxisd(a(t), Eigen::Vector3d::UnitZ()) * Eigen::AngleAxisd(b(t), Eigen::Vector3d::UnitY())).toRotationMatrix();
  }
  static Eigen::Vector3d p(double t) { return {std::sin(t), 0.5 * std::cos(2 * t), 0.3 * std::sin(3 * t)}; }
  static Eigen::Vector3d v(double t) { return {std::cos(t), -std::sin(2 * t), 0.9 * std::cos(3 * t)}; }
  static Eigen::Vector3d acc(double t) { return {-std::sin(t), -2 * std::cos(2 * t), -2.7 * std::sin(3 * t)}; }
  static Eigen::Vector3d omega_b(double t) {
    const Eigen::Matrix3d Ry = Eigen::AngleAxisd(b(t), Eigen::Vector3d::UnitY()).toRotationMatrix();
    return Ry.transpose() * Eigen::Vector3d(0, 0, da(t)) + Eigen::Vector3d(0, db(t), 0);
  }
};

}  // namespace

TEST_CASE("IMU initialization: gyro bias from relative rotations, then gravity and velocities", "[estimator]") {
  const Eigen::Vector3d g_w(0.0, 0.0, -9.81);
  const Eigen::Vector3d bg_true(0.012, -0.02, 0.015);
  const double rate_hz = 400.0, frame_dt = 0.2;
  const int n = 10;
  std::vector<ums::Preintegration> pre(n);
  std::vector<const ums::Preintegration*> ptr(n, nullptr);
  Eigen::Quaterniond q[n];
  Eigen::Vector3d p[n];
  for (int k = 0; k < n; ++k) {
    const double t0 = k * frame_dt;
    q[k] = Eigen::Quaterniond(Motion::R(t0));
    p[k] = Motion::p(t0);
    if (k == 0) continue;
    auto sample = [&](double t) {
      ums::ImuSample s;
      s.t_ns = static_cast<std::int64_t>(std::llround(t * 1e9));
      s.gyro_rad_s = Motion::omega_b(t) + bg_true;
      s.accel_m_s2 = Motion::R(t).transpose() * (Motion::acc(t) - g_w);
      return s;
    };
    const double ta = (k - 1) * frame_dt;
    REQUIRE(pre[k].reset(sample(ta), Eigen::Vector3d::Zero(), Eigen::Vector3d::Zero()) == ums::Status::kOk);
    const int steps = static_cast<int>(std::lround(frame_dt * rate_hz));
    for (int j = 1; j <= steps; ++j) REQUIRE(pre[k].add(sample(ta + j / rate_hz)) == ums::Status::kOk);
    ptr[k] = &pre[k];
  }
  Eigen::Vector3d bg;
  REQUIRE(ums::estimate_gyro_bias(q, ptr.data(), n, &bg) == ums::Status::kOk);
  INFO("gyro bias error " << (bg - bg_true).norm() << " rad/s");
  CHECK((bg - bg_true).norm() < 5e-4);

  ums::GravityVelocity gv;
  REQUIRE(ums::estimate_gravity_velocity(p, q, ptr.data(), n, Eigen::Vector3d::Zero(), bg, &gv) == ums::Status::kOk);
  INFO("gravity " << gv.g_w.transpose() << ", fit RMS " << gv.rms_m << " m");
  CHECK((gv.g_w - g_w).norm() < 0.05);
  for (int k = 0; k < n; ++k) CHECK((gv.v_w[k] - Motion::v(k * frame_dt)).norm() < 0.02);
  CHECK(gv.rms_m < 1e-3);
  // Too few frames: refused.
  CHECK(ums::estimate_gravity_velocity(p, q, ptr.data(), 2, Eigen::Vector3d::Zero(), bg, &gv) == ums::Status::kNotEnoughData);
}

namespace {

// Window of n frames, frame_dt apart, with noise-free IMU from a motion given as attitude,
// acceleration and body rate functions of t.
struct WindowImu {
  static constexpr int kN = 11;
  std::vector<ums::Preintegration> pre = std::vector<ums::Preintegration>(kN);
  const ums::Preintegration* ptr[kN] = {};
  Eigen::Quaterniond q[kN];
};

template <typename Rf, typename Af, typename Wf>
void make_window(Rf R, Af acc, Wf omega_b, double frame_dt, WindowImu* w) {
  const Eigen::Vector3d g_w(0.0, 0.0, -9.81);
  const double rate_hz = 200.0;
  auto sample = [&](double t) {
    ums::ImuSample s;
    s.t_ns = static_cast<std::int64_t>(std::llround(t * 1e9));
    s.gyro_rad_s = omega_b(t);
    s.accel_m_s2 = R(t).transpose() * (acc(t) - g_w);
    return s;
  };
  for (int k = 0; k < WindowImu::kN; ++k) {
    w->q[k] = Eigen::Quaterniond(R(k * frame_dt));
    if (k == 0) continue;
    const double ta = (k - 1) * frame_dt;
    REQUIRE(w->pre[k].reset(sample(ta), Eigen::Vector3d::Zero(), Eigen::Vector3d::Zero()) == ums::Status::kOk);
    const int steps = static_cast<int>(std::lround(frame_dt * rate_hz));
    for (int j = 1; j <= steps; ++j) REQUIRE(w->pre[k].add(sample(ta + j / rate_hz)) == ums::Status::kOk);
    w->ptr[k] = &w->pre[k];
  }
}

}  // namespace

TEST_CASE("alignment observability: rotation reveals gravity's direction, uniform motion does not", "[estimator]") {
  const Eigen::Vector3d g_w(0.0, 0.0, -9.81);
  const double sigma_ba = 0.2;                            // m/s^2, the bias prior
  const double prior_bound_rad = sigma_ba / 9.81;         // tilt known only through the prior
  ums::AlignmentObservability obs;

  SECTION("rotating and accelerating (the analytic motion over 2 s): tilt known to a fraction of a degree") {
    WindowImu w;
    make_window(Motion::R, Motion::acc, Motion::omega_b, 0.2, &w);
    REQUIRE(ums::alignment_observability(w.q, w.ptr, WindowImu::kN, g_w, sigma_ba, &obs) == ums::Status::kOk);
    INFO("tilt sigma " << obs.tilt_sigma_rad * 180 / M_PI << " deg, excitation " << obs.accel_excitation_m_s2);
    CHECK(obs.tilt_sigma_rad * 180.0 / M_PI < 0.2);
    CHECK(obs.ba_sigma_m_s2 < 0.05);
    CHECK(obs.accel_excitation_m_s2 > 1.0);
  }
  SECTION("uniform straight motion: tilt only as good as the bias prior, no excitation") {
    WindowImu w;
    const Eigen::Matrix3d R0 = Eigen::AngleAxisd(0.3, Eigen::Vector3d::UnitZ()).toRotationMatrix();
    make_window([&](double) { return R0; }, [](double) { return Eigen::Vector3d::Zero(); },
                [](double) { return Eigen::Vector3d::Zero(); }, 0.1, &w);
    REQUIRE(ums::alignment_observability(w.q, w.ptr, WindowImu::kN, g_w, sigma_ba, &obs) == ums::Status::kOk);
    CHECK(obs.tilt_sigma_rad == Approx(prior_bound_rad).epsilon(0.02));
    CHECK(obs.ba_sigma_m_s2 == Approx(sigma_ba).epsilon(0.02));
    CHECK(obs.accel_excitation_m_s2 < 1e-6);
  }
  SECTION("vertical bouncing without rotation: excited, yet the tilt still rests on the prior") {
    WindowImu w;
    make_window([](double) { return Eigen::Matrix3d::Identity().eval(); },
                [](double t) { return Eigen::Vector3d(0.0, 0.0, -0.2 * 39.5 * std::sin(6.28 * t)); },
                [](double) { return Eigen::Vector3d::Zero(); }, 0.05, &w);
    REQUIRE(ums::alignment_observability(w.q, w.ptr, WindowImu::kN, g_w, sigma_ba, &obs) == ums::Status::kOk);
    CHECK(obs.tilt_sigma_rad == Approx(prior_bound_rad).epsilon(0.02));
    CHECK(obs.accel_excitation_m_s2 > 2.0);
  }
  SECTION("too few intervals are refused") {
    WindowImu w;
    make_window(Motion::R, Motion::acc, Motion::omega_b, 0.2, &w);
    CHECK(ums::alignment_observability(w.q, w.ptr, 2, g_w, sigma_ba, &obs) == ums::Status::kNotEnoughData);
  }
}
