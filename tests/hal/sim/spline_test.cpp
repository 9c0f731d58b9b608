#include "hal/sim/spline.hpp"

#include <catch2/catch.hpp>

#include <cmath>

#include "core/math/so3.hpp"

using namespace ums::sim;

// The analytic velocity, acceleration and body rate must match central differences of the
// spline's own pose: the IMU is generated from these derivatives.
TEST_CASE("spline derivatives match central differences", "[sim][spline]") {
  std::vector<Eigen::Quaterniond> q;
  std::vector<Eigen::Vector3d> p;
  for (int k = 0; k < 30; ++k) {
    q.emplace_back(ums::so3::exp_quat(Eigen::Vector3d(0.3 * std::sin(0.4 * k), 0.2 * std::cos(0.3 * k), 0.15 * k)));
    p.emplace_back(std::sin(0.2 * k), 0.1 * k * k * 0.05, std::cos(0.5 * k));
  }
  PoseSpline s;
  s.init(1'000'000'000LL, 0.05, q, p);
  const std::int64_t h = 100'000;  // 0.1 ms
  double max_v = 0, max_a = 0, max_w = 0;
  for (std::int64_t t = s.start_ns() + 2 * h; t < s.end_ns() - 2 * h; t += 3'700'000) {
    // Jerk jumps at knots (C2, not C3): keep the finite-difference stencil inside one segment.
    const std::int64_t into_segment = (t - 1'000'000'000LL) % 50'000'000LL;
    if (into_segment < 3 * h || into_segment > 50'000'000LL - 3 * h) continue;
    const SplineState a = s.evaluate(t), m = s.evaluate(t - h), pl = s.evaluate(t + h);
    const double hs = 1e-4;
    max_v = std::max(max_v, (a.v_w_b - (pl.p_w_b - m.p_w_b) / (2 * hs)).norm());
    max_a = std::max(max_a, (a.a_w_b - (pl.v_w_b - m.v_w_b) / (2 * hs)).norm());
    const Eigen::Vector3d w_num = ums::so3::log(m.q_w_b.conjugate() * pl.q_w_b) / (2 * hs);
    max_w = std::max(max_w, (a.omega_b_rad_s - w_num).norm());
  }
  CHECK(max_v < 1e-5);   // m/s
  CHECK(max_a < 1e-3);   // m/s^2
  CHECK(max_w < 1e-4);   // rad/s
  // C2 at knots: acceleration continuous across a knot (difference of one-sided limits).
  const std::int64_t knot = 1'000'000'000LL + 10 * 50'000'000LL;
  CHECK((s.evaluate(knot - 1).a_w_b - s.evaluate(knot + 1).a_w_b).norm() < 1e-3);
}
