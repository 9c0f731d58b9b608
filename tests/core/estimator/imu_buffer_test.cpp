// The estimator's IMU input: an interval is closed at the frame stamp by holding its last sample,
// and a hole in the samples (lost, not slow) marks the interval instead of being held across.
#include "core/estimator/imu_buffer.hpp"

#include <catch2/catch.hpp>

#include <memory>

using ums::ImuBuffer;
using ums::ImuSample;

namespace {

constexpr std::int64_t kMs = 1'000'000;

ImuSample at(std::int64_t t_ns) {
  ImuSample s;
  s.t_ns = t_ns;
  s.accel_m_s2 = Eigen::Vector3d(0.0, 0.0, 9.81);
  return s;
}

}  // namespace

TEST_CASE("IMU buffer: a 200 Hz interval closes at the frame stamp, no gap", "[estimator][imu]") {
  ImuBuffer buf(50 * kMs);
  auto pre = std::make_unique<ums::Preintegration>();
  buf.add(at(0), false);
  buf.open_interval(pre.get(), 2 * kMs, Eigen::Vector3d::Zero(), Eigen::Vector3d::Zero());
  for (std::int64_t t = 5 * kMs; t <= 50 * kMs; t += 5 * kMs) CHECK_FALSE(buf.add(at(t), false).after_gap);
  REQUIRE(buf.close_interval(52 * kMs));
  CHECK_FALSE(buf.interval_has_gap());
  CHECK(pre->num_samples() == 12);  // the opening boundary, 10 samples, the closing hold
}

TEST_CASE("IMU buffer: samples lost inside an interval mark it", "[estimator][imu]") {
  ImuBuffer buf(50 * kMs);
  auto pre = std::make_unique<ums::Preintegration>();
  buf.add(at(0), false);
  buf.open_interval(pre.get(), 0, Eigen::Vector3d::Zero(), Eigen::Vector3d::Zero());
  buf.add(at(5 * kMs), false);
  CHECK(buf.add(at(80 * kMs), false).after_gap);  // 75 ms without a sample
  REQUIRE(buf.close_interval(100 * kMs));
  CHECK(buf.interval_has_gap());
  // The next interval starts clean.
  buf.open_interval(pre.get(), 100 * kMs, Eigen::Vector3d::Zero(), Eigen::Vector3d::Zero());
  CHECK_FALSE(buf.interval_has_gap());
}

// The clock stepped back by 0.5 s: the samples stamped before the last one were dropped upstream,
// but 0.5 s passed. The stamps show a 5 ms step; the interval is marked as across a 0.5 s hole.
TEST_CASE("IMU buffer: time lost to a clock stepping back marks the interval as a hole that long", "[estimator][imu]") {
  ImuBuffer buf(50 * kMs);
  auto pre = std::make_unique<ums::Preintegration>();
  buf.add(at(0), false);
  buf.open_interval(pre.get(), 0, Eigen::Vector3d::Zero(), Eigen::Vector3d::Zero());
  buf.add(at(5 * kMs), false);
  buf.note_lost_time(500 * kMs);
  CHECK_FALSE(buf.add(at(10 * kMs), false).after_gap);  // the stamps alone show no hole
  REQUIRE(buf.close_interval(50 * kMs));
  CHECK(buf.interval_has_gap());
  CHECK(buf.interval_hole_s() == Approx(0.5));
  CHECK(buf.hole_age_s() == Approx(0.5));
  buf.open_interval(pre.get(), 50 * kMs, Eigen::Vector3d::Zero(), Eigen::Vector3d::Zero());
  CHECK_FALSE(buf.interval_has_gap());
  buf.note_lost_time(0);  // nothing lost: nothing marked
  CHECK_FALSE(buf.interval_has_gap());
}

TEST_CASE("IMU buffer: a frame inside a hole, at either end of its interval, marks it", "[estimator][imu]") {
  ImuBuffer buf(50 * kMs);
  auto pre = std::make_unique<ums::Preintegration>();
  buf.add(at(0), false);
  buf.open_interval(pre.get(), 10 * kMs, Eigen::Vector3d::Zero(), Eigen::Vector3d::Zero());
  REQUIRE(buf.close_interval(60 * kMs));  // nothing since 0: the hold would cover 60 ms
  CHECK(buf.interval_has_gap());
  buf.open_interval(pre.get(), 60 * kMs, Eigen::Vector3d::Zero(), Eigen::Vector3d::Zero());
  CHECK(buf.interval_has_gap());  // still inside the hole when the interval opens
  // A slow but steady sensor (a 30 Hz accel) is no hole at the default 50 ms.
  ImuBuffer slow(50 * kMs);
  slow.add(at(0), false);
  slow.open_interval(pre.get(), 0, Eigen::Vector3d::Zero(), Eigen::Vector3d::Zero());
  for (std::int64_t t = 33 * kMs; t <= 330 * kMs; t += 33 * kMs) CHECK_FALSE(slow.add(at(t), false).after_gap);
  REQUIRE(slow.close_interval(340 * kMs));
  CHECK_FALSE(slow.interval_has_gap());
}

// A frame inside a hole gets an interval of the held sample alone. One step of it would give
// alpha and beta their noise from the same inputs (rank 3 of 6: no whitening, so no IMU factor,
// and the frame's velocity and biases float free); the buffer adds a step halfway.
TEST_CASE("IMU buffer: an interval inside a hole has two steps and a full-rank covariance", "[estimator][imu]") {
  ImuBuffer buf(50 * kMs);
  auto pre = std::make_unique<ums::Preintegration>();
  ums::Preintegration::Matrix15 U;
  // One step of a held sample, as the buffer used to make it: singular.
  REQUIRE(pre->reset(at(100 * kMs), Eigen::Vector3d::Zero(), Eigen::Vector3d::Zero()) == ums::Status::kOk);
  REQUIRE(pre->add(at(150 * kMs)) == ums::Status::kOk);
  CHECK(pre->sqrt_information(&U) == ums::Status::kSingular);
  // Through the buffer: the last sample at 0, frames at 100 and 150 ms.
  buf.add(at(0), false);
  buf.open_interval(pre.get(), 100 * kMs, Eigen::Vector3d::Zero(), Eigen::Vector3d::Zero());
  REQUIRE(buf.close_interval(150 * kMs));
  CHECK(buf.interval_has_gap());
  CHECK(pre->num_samples() == 3);
  CHECK(pre->sample(1).t_ns == 125 * kMs);
  CHECK(pre->sqrt_information(&U) == ums::Status::kOk);
  CHECK(buf.interval_hole_s() == Approx(0.050));
  CHECK(buf.hole_age_s() == Approx(0.150));  // held since the sample at 0
  // The hole ends inside the next interval: the first sample after it is reached in two steps.
  buf.open_interval(pre.get(), 150 * kMs, Eigen::Vector3d::Zero(), Eigen::Vector3d::Zero());
  CHECK(buf.add(at(190 * kMs), false).after_gap);
  buf.add(at(195 * kMs), false);
  REQUIRE(buf.close_interval(200 * kMs));
  CHECK(pre->num_samples() == 5);  // 150, 170 (halfway), 190, 195, 200
  CHECK(buf.interval_hole_s() == Approx(0.040));
  CHECK(buf.hole_age_s() == Approx(0.190));
  CHECK(pre->sqrt_information(&U) == ums::Status::kOk);
  // A steady interval is left as it was: no added samples.
  buf.open_interval(pre.get(), 200 * kMs, Eigen::Vector3d::Zero(), Eigen::Vector3d::Zero());
  for (std::int64_t t = 205 * kMs; t <= 250 * kMs; t += 5 * kMs) buf.add(at(t), false);
  REQUIRE(buf.close_interval(250 * kMs));
  CHECK_FALSE(buf.interval_has_gap());
  CHECK(pre->num_samples() == 11);
}

// The motion before a hole sets how far a held sample may drift: a gyro ramping at 2 rad/s^2 and
// an accel at 4 m/s^3, sampled at 200 Hz, change by 0.01 rad/s and 0.02 m/s^2 per step:
// q = step^2 / dt = 2e-2 rad^2/s^3 and 8e-2 m^2/s^5.
TEST_CASE("IMU buffer: the motion density before a hole is the samples' step^2 / dt", "[estimator][imu]") {
  ImuBuffer buf(50 * kMs);
  double q_gyro = 0.0, q_accel = 0.0;
  CHECK_FALSE(buf.motion_density_before_hole(&q_gyro, &q_accel));  // nothing seen yet
  auto pre = std::make_unique<ums::Preintegration>();
  for (std::int64_t t = 0; t <= 2000 * kMs; t += 5 * kMs) {
    ImuSample s = at(t);
    const double t_s = 1e-9 * static_cast<double>(t);
    s.gyro_rad_s = Eigen::Vector3d(2.0 * t_s, -2.0 * t_s, 2.0 * t_s);
    s.accel_m_s2 += Eigen::Vector3d(4.0 * t_s, 4.0 * t_s, -4.0 * t_s);
    buf.add(s, false);
  }
  buf.open_interval(pre.get(), 2000 * kMs, Eigen::Vector3d::Zero(), Eigen::Vector3d::Zero());
  REQUIRE(buf.close_interval(2100 * kMs));  // 100 ms without samples
  REQUIRE(buf.motion_density_before_hole(&q_gyro, &q_accel));
  CHECK(q_gyro == Approx(0.01 * 0.01 / 0.005).epsilon(1e-6));
  CHECK(q_accel == Approx(0.02 * 0.02 / 0.005).epsilon(1e-6));
}
