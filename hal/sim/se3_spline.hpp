#pragma once
// Uniform cumulative cubic B-spline on SE(3) (rotation and translation coupled): the photo
// style's continuous body trajectory (the procedural style uses PoseSpline on SO(3) x R3).
// Control poses T_k at t0 + k dt; on segment i (t in [t_i, t_i+1), u = (t - t_i)/dt)
//   T(t) = T_{i-1} prod_{j=1..3} Exp(Bc_j(u) xi_{i+j-1}),   xi_k = Log(T_{k-1}^-1 T_k),
// with the cumulative cubic basis of spline.hpp (Bc_1 + Bc_2 + Bc_3 = 1 + u). The translation
// follows the screw motion of each increment, so position and attitude are not independent
// curves as in PoseSpline. Equal increments (constant velocity and attitude, or rest) give
// T(t) = T_{i-1} Exp((1 + u) xi): exactly uniform motion.
// Only the pose is evaluated: the photo IMU is differenced from it (decimated_imu.hpp), which
// keeps the sensor model independent of the spline's analytic derivatives.
// Start-up/tool code: std::vector storage.

#include <cstdint>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>

namespace ums::sim {

class Se3Spline {
 public:
  // Needs >= 4 control poses and dt_s > 0. Throws std::runtime_error otherwise.
  void init(std::int64_t t0_ns, double dt_s, std::vector<Eigen::Isometry3d> T_w_b);
  std::int64_t start_ns() const;  // first valid time (t0 + dt)
  std::int64_t end_ns() const;    // last valid time (t0 + (N - 2) dt)
  // Body pose at t_ns, clamped into [start_ns, end_ns].
  Eigen::Isometry3d evaluate(std::int64_t t_ns) const;
  std::size_t size() const { return T_.size(); }

 private:
  std::int64_t t0_ns_ = 0;
  double dt_s_ = 0.05;
  std::vector<Eigen::Isometry3d> T_;
  std::vector<Eigen::Matrix<double, 6, 1>> xi_;  // xi_k = Log(T_{k-1}^-1 T_k), [rho, phi], k >= 1
};

}  // namespace ums::sim
