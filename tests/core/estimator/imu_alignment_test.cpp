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
