#pragma once
// Uniform cumulative cubic B-spline on SO(3) x R3 (C2): the simulator's continuous body
// trajectory. Control points k at t0 + k dt; on segment i (t in [t_i, t_i+1), u = (t - t_i)/dt)
//   R(t) = R_{i-1} prod_{j=1..3} exp(Bc_j(u) log(R_{i+j-2}^T R_{i+j-1})),
//   p(t) = p_{i-1} + sum_j Bc_j(u) (p_{i+j-1} - p_{i+j-2}),
// with the cumulative basis Bc_1 = (5 + 3u - 3u^2 + u^3)/6, Bc_2 = (1 + 3u + 3u^2 - 2u^3)/6,
// Bc_3 = u^3/6. Using the (resampled) ground-truth poses as control points makes it a smoothing
// (approximating) spline: at a knot it passes (p_{i-1} + 4 p_i + p_{i+1})/6, no time lag.
// Body angular rate from the analytic derivative: w_j = A_j^T w_{j-1} + dBc_j d_j, A_j = exp(Bc_j d_j).
// Start-up/tool code: std::vector storage.

#include <cstdint>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>

namespace ums::sim {

struct SplineState {
  Eigen::Quaterniond q_w_b = Eigen::Quaterniond::Identity();  // body -> world
  Eigen::Vector3d p_w_b = Eigen::Vector3d::Zero();            // m
  Eigen::Vector3d v_w_b = Eigen::Vector3d::Zero();            // m/s, world
  Eigen::Vector3d a_w_b = Eigen::Vector3d::Zero();            // m/s^2, world (no gravity)
  Eigen::Vector3d omega_b_rad_s = Eigen::Vector3d::Zero();    // body angular rate, body frame
};

class PoseSpline {
 public:
  // Needs >= 4 control points. Throws std::runtime_error otherwise.
  void init(std::int64_t t0_ns, double dt_s, std::vector<Eigen::Quaterniond> q_w_b,
            std::vector<Eigen::Vector3d> p_w_b);
  std::int64_t start_ns() const;  // first valid time (t0 + dt)
  std::int64_t end_ns() const;    // last valid time (t0 + (N - 2) dt)
  // Clamps t into [start_ns, end_ns].
  SplineState evaluate(std::int64_t t_ns) const;
  std::size_t size() const { return p_.size(); }

 private:
  std::int64_t t0_ns_ = 0;
  double dt_s_ = 0.05;
  std::vector<Eigen::Quaterniond> q_;
  std::vector<Eigen::Vector3d> p_;
  std::vector<Eigen::Vector3d> d_;  // d_k = log(R_{k-1}^T R_k), k >= 1
};

}  // namespace ums::sim
