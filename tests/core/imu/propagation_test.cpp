#include "core/imu/propagation.hpp"

#include <catch2/catch.hpp>

#include "core/imu/preintegration.hpp"
#include "core/math/so3.hpp"
#include "synthetic_imu.hpp"

namespace {
using Eigen::Vector3d;
using ums::Status;
using ums::test::kImuPeriodNs;
using ums::test::SyntheticTrajectory;

ums::NavState true_state(const SyntheticTrajectory& traj, double t) {
  ums::NavState s;
  s.t_ns = static_cast<std::int64_t>(t * 1e9);
  s.p_w_b = traj.p(t);
  s.q_w_b = traj.q(t);
  s.v_w_b = traj.v(t);
  s.ba = traj.ba;
  s.bg = traj.bg;
  return s;
}
}  // namespace

TEST_CASE("propagation at IMU rate follows a known trajectory", "[imu][propagation]") {
  SyntheticTrajectory traj;
  traj.ba = Vector3d(0.1, 0.0, -0.05);
  traj.bg = Vector3d(0.0, 0.01, 0.0);
  ums::ImuPropagator prop(traj.g_w);
  prop.reset(true_state(traj, 0.0), traj.sample(0));
  for (int k = 1; k <= 400; ++k)
    REQUIRE(prop.propagate(traj.sample(k * kImuPeriodNs)) == Status::kOk);
  const ums::NavState& s = prop.state();
  CHECK(s.t_ns == 400 * kImuPeriodNs);
  // 2 s of dead reckoning from perfect samples: only the midpoint-rule error remains.
  CHECK((s.p_w_b - traj.p(2.0)).norm() < 2e-4);                                          // m
  CHECK((s.v_w_b - traj.v(2.0)).norm() < 2e-4);                                          // m/s
  CHECK(ums::so3::angle(Eigen::Quaterniond(s.q_w_b.conjugate() * traj.q(2.0))) < 1e-4);  // rad
  CHECK(prop.propagate(traj.sample(400 * kImuPeriodNs)) == Status::kInvalidInput);
}

TEST_CASE("propagation and preintegration predict the same state", "[imu][propagation]") {
  SyntheticTrajectory traj;
  const ums::NavState si = true_state(traj, 0.0);
  ums::ImuPropagator prop(traj.g_w);
  prop.reset(si, traj.sample(0));
  ums::Preintegration pre;
  REQUIRE(pre.reset(traj.sample(0), si.ba, si.bg) == Status::kOk);
  for (int k = 1; k <= 100; ++k) {
    const ums::ImuSample s = traj.sample(k * kImuPeriodNs);
    REQUIRE(prop.propagate(s) == Status::kOk);
    REQUIRE(pre.add(s) == Status::kOk);
  }
  const ums::NavState sj = ums::predict(si, pre, traj.g_w);
  // The two are the same midpoint scheme in different frames: equal to rounding.
  CHECK((sj.p_w_b - prop.state().p_w_b).norm() < 1e-10);
  CHECK((sj.v_w_b - prop.state().v_w_b).norm() < 1e-10);
  CHECK(ums::so3::angle(Eigen::Quaterniond(sj.q_w_b.conjugate() * prop.state().q_w_b)) < 1e-12);
  CHECK(sj.t_ns == prop.state().t_ns);
}

TEST_CASE("propagation rejects use before reset", "[imu][propagation]") {
  ums::ImuPropagator prop;
  CHECK_FALSE(prop.initialized());
  CHECK(prop.propagate(ums::ImuSample()) == Status::kInvalidInput);
}
