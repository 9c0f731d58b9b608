#include "hal/sim/se3_spline.hpp"

#include <catch2/catch.hpp>

#include <cmath>
#include <vector>

#include "core/math/se3.hpp"
#include "core/math/so3.hpp"
#include "hal/sim/spline.hpp"

using namespace ums::sim;

namespace {

constexpr std::int64_t kT0 = 1'000'000'000LL;
constexpr std::int64_t kDtNs = 50'000'000LL;

struct Controls {
  std::vector<Eigen::Quaterniond> q;
  std::vector<Eigen::Vector3d> p;
  std::vector<Eigen::Isometry3d> T;
};

Controls wavy_controls() {
  Controls c;
  for (int k = 0; k < 30; ++k) {
    c.q.emplace_back(ums::so3::exp_quat(Eigen::Vector3d(0.3 * std::sin(0.4 * k), 0.2 * std::cos(0.3 * k), 0.15 * k)));
    c.p.emplace_back(std::sin(0.2 * k), 0.1 * k * k * 0.05, std::cos(0.5 * k));
    c.T.push_back(ums::se3::make(c.q.back(), c.p.back()));
  }
  return c;
}

}  // namespace

// The rotation part of a cumulative SE(3) spline is the cumulative SO(3) spline of the same
// control rotations (Exp of an se(3) increment rotates by Exp of its phi); the translation is
// coupled to the rotation and so differs from PoseSpline's R3 curve, but stays close to it.
TEST_CASE("SE(3) spline: rotation equals the SO(3) spline, translation coupled but close", "[sim][se3_spline]") {
  const Controls c = wavy_controls();
  Se3Spline s;
  s.init(kT0, 0.05, c.T);
  PoseSpline r;
  r.init(kT0, 0.05, c.q, c.p);
  REQUIRE(s.start_ns() == r.start_ns());
  REQUIRE(s.end_ns() == r.end_ns());
  double max_rot = 0.0, max_dp = 0.0;
  for (std::int64_t t = s.start_ns(); t <= s.end_ns(); t += 3'700'000) {
    const Eigen::Isometry3d T = s.evaluate(t);
    const SplineState st = r.evaluate(t);
    max_rot = std::max(max_rot, ums::so3::angle(Eigen::Quaterniond(T.linear()).conjugate() * st.q_w_b));
    max_dp = std::max(max_dp, (T.translation() - st.p_w_b).norm());
  }
  CHECK(max_rot < 1e-12);
  CHECK(max_dp > 1e-4);   // a different curve ...
  CHECK(max_dp < 0.05);   // ... through the same control poses (0.15 rad and ~0.1 m per knot)
}

// Equal increments give exactly uniform motion (the uniform-start scenario relies on it).
TEST_CASE("SE(3) spline: equal increments are constant velocity and attitude", "[sim][se3_spline]") {
  const Eigen::Quaterniond q = ums::so3::exp_quat(Eigen::Vector3d(0.1, -0.2, 0.7));
  const Eigen::Vector3d v(0.6, -0.3, 0.05);  // m/s
  std::vector<Eigen::Isometry3d> T;
  for (int k = 0; k < 12; ++k) T.push_back(ums::se3::make(q, Eigen::Vector3d(1, 2, 1.5) + v * (0.05 * k)));
  Se3Spline s;
  s.init(kT0, 0.05, T);
  const std::int64_t h = 1'000'000;  // 1 ms
  for (std::int64_t t = s.start_ns() + h; t < s.end_ns() - h; t += 7'300'000) {
    const Eigen::Isometry3d a = s.evaluate(t - h), b = s.evaluate(t), c = s.evaluate(t + h);
    CHECK(ums::so3::angle(Eigen::Quaterniond(b.linear()).conjugate() * q) < 1e-12);
    CHECK(((c.translation() - a.translation()) / 2e-3 - v).norm() < 1e-9);
    CHECK((c.translation() - 2.0 * b.translation() + a.translation()).norm() / 1e-6 < 1e-6);  // m/s^2
  }
}

// C2: the acceleration from second differences is continuous across a knot (jumps only in jerk).
TEST_CASE("SE(3) spline: acceleration continuous across knots", "[sim][se3_spline]") {
  const Controls c = wavy_controls();
  Se3Spline s;
  s.init(kT0, 0.05, c.T);
  const std::int64_t h = 200'000;  // 0.2 ms
  auto accel = [&](std::int64_t t) {
    return ((s.evaluate(t + h).translation() - 2.0 * s.evaluate(t).translation() + s.evaluate(t - h).translation()) /
            (0.2e-3 * 0.2e-3))
        .eval();
  };
  double worst_gap = 0.0, scale = 0.0;
  for (int k = 3; k < 25; k += 5) {
    const std::int64_t knot = kT0 + k * kDtNs;
    // One-sided limits at the knot, linearly extrapolated from stencils wholly on either side
    // (error O(h^2)): equal for a C2 curve, apart by the jump for a C1 one.
    const Eigen::Vector3d before = 2.0 * accel(knot - h) - accel(knot - 2 * h);
    const Eigen::Vector3d after = 2.0 * accel(knot + h) - accel(knot + 2 * h);
    worst_gap = std::max(worst_gap, (before - after).norm());
    scale = std::max(scale, before.norm());
  }
  INFO("largest acceleration gap at a knot " << worst_gap << " m/s^2 (accelerations up to " << scale << ")");
  CHECK(worst_gap < 1e-3);
  CHECK(scale > 1.0);
  CHECK_THROWS(s.init(kT0, 0.05, std::vector<Eigen::Isometry3d>(3, Eigen::Isometry3d::Identity())));
}
