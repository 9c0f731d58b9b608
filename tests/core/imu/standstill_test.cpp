#include "core/imu/standstill.hpp"

#include <catch2/catch.hpp>
#include <cmath>
#include <random>
#include <stdexcept>
#include <vector>

#include "core/math/quaternion.hpp"
#include "core/math/so3.hpp"
#include "synthetic_imu.hpp"

namespace {
using Eigen::Vector3d;
using ums::Status;
using ums::test::kImuPeriodNs;

// A resting IMU tilted by R_w_b, with a gyro bias and white noise at the given densities.
std::vector<ums::ImuSample> resting(const Eigen::Matrix3d& R_w_b, const Vector3d& bg,
                                    const ums::ImuNoise& noise, double seconds, unsigned seed) {
  std::mt19937 rng(seed);
  std::normal_distribution<double> n01(0.0, 1.0);
  const double rate = 200.0;
  const double sg = noise.gyro_noise_density * std::sqrt(rate);
  const double sa = noise.accel_noise_density * std::sqrt(rate);
  std::vector<ums::ImuSample> out;
  for (int k = 0; k < static_cast<int>(seconds * rate); ++k) {
    ums::ImuSample s;
    s.t_ns = k * kImuPeriodNs;
    s.gyro_rad_s = bg + sg * Vector3d(n01(rng), n01(rng), n01(rng));
    s.accel_m_s2 =
        R_w_b.transpose() * Vector3d(0, 0, 9.81) + sa * Vector3d(n01(rng), n01(rng), n01(rng));
    out.push_back(s);
  }
  return out;
}
}  // namespace

TEST_CASE("standstill: a noisy resting IMU is at rest, with its bias and roll/pitch",
          "[imu][standstill]") {
  const ums::ImuNoise noise;
  const ums::StandstillOptions opt;
  const Eigen::Matrix3d R_w_b =
      (Eigen::AngleAxisd(0.7, Vector3d::UnitZ()) * Eigen::AngleAxisd(-0.2, Vector3d::UnitY()) *
       Eigen::AngleAxisd(0.15, Vector3d::UnitX()))
          .toRotationMatrix();
  const Vector3d bg(0.002, -0.02, 0.07);
  const auto samples = resting(R_w_b, bg, noise, 2.0, 1);
  ums::StandstillResult r;
  REQUIRE(ums::detect_standstill(samples.data(), samples.size(), noise, opt, &r) == Status::kOk);
  CHECK(r.at_rest);
  // Bias: mean of 400 samples of 0.0024 rad/s noise -> ~1.2e-4 rad/s.
  CHECK((r.mean_gyro_rad_s - bg).norm() < 6e-4);
  // Attitude: roll and pitch recovered (gravity direction in the body), yaw set to 0.
  const Eigen::Matrix3d R_est = r.q_w_b.toRotationMatrix();
  CHECK(std::abs(ums::quat::yaw(R_est)) < 1e-12);
  const double tilt_err = std::acos(std::min(
      1.0, (R_est.transpose() * Vector3d::UnitZ()).dot(R_w_b.transpose() * Vector3d::UnitZ())));
  CHECK(tilt_err < 1e-3);  // rad
  CHECK(ums::so3::angle(Eigen::Matrix3d(R_est.transpose() * ums::quat::remove_yaw(R_w_b))) < 1e-3);
}

TEST_CASE("standstill: slow rotation or translation is motion", "[imu][standstill]") {
  const ums::ImuNoise noise;
  const ums::StandstillOptions opt;
  ums::test::SyntheticTrajectory traj;  // ~0.5-1 rad/s, ~1 m/s^2
  std::vector<ums::ImuSample> samples;
  for (int k = 0; k < 200; ++k) samples.push_back(traj.sample(k * kImuPeriodNs));
  ums::StandstillResult r;
  REQUIRE(ums::detect_standstill(samples.data(), samples.size(), noise, opt, &r) == Status::kOk);
  CHECK_FALSE(r.at_rest);
  CHECK(r.gyro_spread_rad_s > r.gyro_threshold_rad_s);
  // Too short a window is not judged.
  CHECK(ums::detect_standstill(samples.data(), 50, noise, opt, &r) == Status::kNotEnoughData);
  // A tilted-but-wrong gravity magnitude (e.g. sustained acceleration) is not rest either.
  auto still = resting(Eigen::Matrix3d::Identity(), Vector3d::Zero(), noise, 1.0, 3);
  for (auto& s : still) s.accel_m_s2 *= 1.1;
  REQUIRE(ums::detect_standstill(still.data(), still.size(), noise, opt, &r) == Status::kOk);
  CHECK_FALSE(r.at_rest);
  ums::StandstillOptions bad;
  bad.gyro_multiplier = 0.0;
  CHECK_THROWS_AS(bad.validate(), std::invalid_argument);
  CHECK_NOTHROW(opt.validate());
}
