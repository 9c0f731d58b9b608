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
