#pragma once
// A smooth analytic trajectory and the ideal IMU samples it produces (tests only).
//   p(t) = [2 sin 0.7t, 1.5 cos 0.5t, 0.3 sin 1.1t] m
//   R(t) = Exp(u1 th1(t)) Exp(u2 th2(t)),  th1 = 0.8 sin 0.9t,  th2 = 0.5t + 0.3 sin 1.7t
//   gyro  = Exp(u2 th2)^T u1 th1' + u2 th2'   (R' = R [gyro]x)
//   accel = R^T (p'' - g_w) + b_a,  gyro + b_g

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <cmath>
#include <cstdint>

#include "core/common/imu_sample.hpp"
#include "core/math/so3.hpp"

namespace ums::test {

struct SyntheticTrajectory {
  Eigen::Vector3d g_w = Eigen::Vector3d(0.0, 0.0, -9.81);
  Eigen::Vector3d ba = Eigen::Vector3d::Zero();
  Eigen::Vector3d bg = Eigen::Vector3d::Zero();
  Eigen::Vector3d u1 = Eigen::Vector3d(0.3, 0.2, 0.93).normalized();
  Eigen::Vector3d u2 = Eigen::Vector3d::UnitX();

  Eigen::Vector3d p(double t) const {
    return Eigen::Vector3d(2.0 * std::sin(0.7 * t), 1.5 * std::cos(0.5 * t),
                           0.3 * std::sin(1.1 * t));
  }
  Eigen::Vector3d v(double t) const {
    return Eigen::Vector3d(1.4 * std::cos(0.7 * t), -0.75 * std::sin(0.5 * t),
                           0.33 * std::cos(1.1 * t));
  }
  Eigen::Vector3d a(double t) const {
    return Eigen::Vector3d(-0.98 * std::sin(0.7 * t), -0.375 * std::cos(0.5 * t),
                           -0.363 * std::sin(1.1 * t));
  }
  double th1(double t) const { return 0.8 * std::sin(0.9 * t); }
  double th1_dot(double t) const { return 0.72 * std::cos(0.9 * t); }
  double th2(double t) const { return 0.5 * t + 0.3 * std::sin(1.7 * t); }
  double th2_dot(double t) const { return 0.5 + 0.51 * std::cos(1.7 * t); }
  Eigen::Matrix3d R(double t) const { return so3::exp(u1 * th1(t)) * so3::exp(u2 * th2(t)); }
  Eigen::Quaterniond q(double t) const { return Eigen::Quaterniond(R(t)).normalized(); }

  ImuSample sample(std::int64_t t_ns) const {
    const double t = 1e-9 * static_cast<double>(t_ns);
    ImuSample s;
    s.t_ns = t_ns;
    s.gyro_rad_s = so3::exp(u2 * th2(t)).transpose() * u1 * th1_dot(t) + u2 * th2_dot(t) + bg;
    s.accel_m_s2 = R(t).transpose() * (a(t) - g_w) + ba;
    return s;
  }
};

inline constexpr std::int64_t kImuPeriodNs = 5'000'000;  // 200 Hz

}  // namespace ums::test
