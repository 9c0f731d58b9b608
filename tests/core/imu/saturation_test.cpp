#include "core/imu/saturation.hpp"

#include <catch2/catch.hpp>
#include <cmath>
#include <limits>
#include <stdexcept>

#include "synthetic_imu.hpp"

namespace {
using Eigen::Vector3d;
using ums::test::kImuPeriodNs;
}  // namespace

TEST_CASE("saturation clips a 50 m/s^2 spike on one sample", "[imu][saturation]") {
  ums::SaturationOptions opt;
  ums::SaturationElement sat(opt);
  ums::ImuSample s, out;
  s.accel_m_s2 = Vector3d(0.1, -0.2, 9.81);
  s.gyro_rad_s = Vector3d(0.01, 0.02, -0.01);
  for (int k = 0; k < 5; ++k) {
    s.t_ns = k * kImuPeriodNs;
    CHECK_FALSE(sat.apply(s, &out));
  }
  ums::ImuSample spike = s;
  spike.t_ns = 5 * kImuPeriodNs;
  spike.accel_m_s2.y() += 50.0;
  CHECK(sat.apply(spike, &out));
  CHECK(out.accel_m_s2.y() == Approx(s.accel_m_s2.y() + opt.max_accel_step_m_s2));  // limited
  CHECK(out.accel_m_s2.x() == s.accel_m_s2.x());  // other axes untouched
  CHECK(out.gyro_rad_s == s.gyro_rad_s);
  // Back to normal: the step down from the clipped value is within the bound, passes as is.
  s.t_ns = 6 * kImuPeriodNs;
  CHECK_FALSE(sat.apply(s, &out));
  CHECK(out.accel_m_s2 == s.accel_m_s2);
  CHECK(sat.saturated_samples() == 1);
  CHECK(sat.saturated_axes() == 1);
  CHECK(sat.processed_samples() == 7);
  // A gyro spike too.
  ums::ImuSample gspike = s;
  gspike.t_ns = 7 * kImuPeriodNs;
  gspike.gyro_rad_s.z() -= 5.0;
  CHECK(sat.apply(gspike, &out));
  CHECK(out.gyro_rad_s.z() == Approx(s.gyro_rad_s.z() - opt.max_gyro_step_rad_s));
  CHECK(sat.saturated_samples() == 2);
}

TEST_CASE("saturation leaves a smooth aggressive manoeuvre untouched", "[imu][saturation]") {
  // Synthetic flight with rates ~1 rad/s and accelerations ~1 m/s^2, plus a fast 3 Hz wobble
  // of 2 rad/s and 15 m/s^2 amplitude: the per-sample change stays well under the bounds.
  ums::test::SyntheticTrajectory traj;
  ums::SaturationElement sat{ums::SaturationOptions()};
  const double w = 2.0 * 3.14159265358979 * 3.0;
  for (int k = 0; k < 2000; ++k) {
    ums::ImuSample s = traj.sample(k * kImuPeriodNs);
    const double t = 1e-9 * static_cast<double>(s.t_ns);
    s.gyro_rad_s += Vector3d(2.0, -2.0, 2.0) * std::sin(w * t);
    s.accel_m_s2 += Vector3d(15.0, 15.0, -15.0) * std::cos(w * t);
    ums::ImuSample out;
    sat.apply(s, &out);
    REQUIRE(out.accel_m_s2 == s.accel_m_s2);
    REQUIRE(out.gyro_rad_s == s.gyro_rad_s);
  }
  CHECK(sat.saturated_samples() == 0);
}

TEST_CASE("saturation can be disabled and validates its bounds", "[imu][saturation]") {
  ums::SaturationOptions opt;
  opt.enabled = false;
  ums::SaturationElement sat(opt);
  ums::ImuSample a, b, out;
  b.accel_m_s2.x() = 100.0;
  sat.apply(a, &out);
  CHECK_FALSE(sat.apply(b, &out));
  CHECK(out.accel_m_s2.x() == 100.0);
  opt.max_accel_step_m_s2 = -1.0;
  CHECK_THROWS_AS(opt.validate(), std::invalid_argument);
  opt.max_accel_step_m_s2 = 30.0;
  opt.max_gyro_step_rad_s = std::nan("");
  CHECK_THROWS_AS(opt.validate(), std::invalid_argument);
}

// A reading no IMU can make is refused outright (the limiter would ramp a sustained 1e9 in, and
// lets a NaN through every comparison); the range is the widest MEMS IMUs offer.
TEST_CASE("saturation: NaN, Inf and beyond-range samples are no reading, in-range ones are", "[imu][saturation]") {
  ums::SaturationElement sat;
  ums::ImuSample s;
  s.accel_m_s2 = Eigen::Vector3d(0.3, -0.2, 9.81);
  s.gyro_rad_s = Eigen::Vector3d(0.1, 0.0, -0.2);
  CHECK(sat.plausible(s));
  ums::ImuSample fast = s;
  fast.gyro_rad_s.z() = 34.9;   // 2000 deg/s, the D455's BMI055 full scale
  fast.accel_m_s2.x() = -156.9;  // 16 g
  CHECK(sat.plausible(fast));
  int refused = 0;
  for (double bad : {std::nan(""), std::numeric_limits<double>::infinity(), 1e9, 71.0}) {
    ums::ImuSample g = s;
    g.gyro_rad_s.y() = bad;
    CHECK_FALSE(sat.plausible(g));
    ums::ImuSample a = s;
    a.accel_m_s2.z() = bad == 71.0 ? 321.0 : -bad;
    CHECK_FALSE(sat.plausible(a));
    refused += 2;
  }
  CHECK(sat.implausible_samples() == static_cast<std::uint64_t>(refused));
  ums::SaturationOptions opt;
  opt.max_abs_accel_m_s2 = 0.0;
  CHECK_THROWS_WITH(opt.validate(), Catch::Contains("max_abs_accel_m_s2"));
}
