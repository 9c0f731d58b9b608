#pragma once
// IMU initialization of the visual-IMU alignment (paper Sec. III-B, case 2, step 1), given body
// poses from stereo vision (metric: stereo fixes the scale, so no scale is estimated):
//  1. gyroscope bias from the relative rotations: for each interval, gamma(bg) ~ q_i^-1 q_j with
//     gamma(bg) = gamma Exp(J_gamma_bg (bg - bg_lin)), linear least squares over all intervals;
//  2. gravity and velocities from the discrete preintegration equations
//       p_j = p_i + v_i dt + 1/2 g dt^2 + R_i alpha,   v_j = v_i + g dt + R_i beta,
//     linear least squares in [v_0 .. v_n-1, g];
//  3. what the window knows about gravity's direction and the accelerometer bias (observability):
//     the same equations, linearized in [v_0 .. v_n-1, tilt (2), b_a (3)] and weighted by the
//     preintegrated covariance, with the prior on b_a; the marginal covariance of tilt and b_a
//     (velocities eliminated) says whether the alignment can be trusted. Without rotation a tilt
//     and a bias are the same measurement (R^T g + b_a), so the tilt is then known only as well
//     as the prior knows the bias (sigma_ba / g): the uniform-motion case of the paper.
// Frames are passed as arrays indexed 0..n-1; pre[k] (k >= 1) integrates frame k-1 to frame k.

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "core/common/status.hpp"
#include "core/imu/preintegration.hpp"

namespace ums {

// kNotEnoughData with fewer than two usable intervals; kSingular if the system is degenerate.
Status estimate_gyro_bias(const Eigen::Quaterniond* q_w_b, const Preintegration* const* pre, int n,
                          Eigen::Vector3d* bg);

struct GravityVelocity {
  Eigen::Vector3d g_w = Eigen::Vector3d::Zero();   // m/s^2, gravity in the frame of the poses
  Eigen::Vector3d v_w[16];                          // m/s, per frame (n <= 16)
  double rms_m = 0.0;                               // RMS of the equation residuals
};

Status estimate_gravity_velocity(const Eigen::Vector3d* p_w_b, const Eigen::Quaterniond* q_w_b,
                                 const Preintegration* const* pre, int n, const Eigen::Vector3d& ba,
                                 const Eigen::Vector3d& bg, GravityVelocity* out);

struct AlignmentObservability {
  double tilt_sigma_rad = 0.0;   // rad, largest standard deviation of the gravity direction
  double ba_sigma_m_s2 = 0.0;    // m/s^2, largest standard deviation of the accelerometer bias
  // m/s^2, RMS deviation of the intervals' mean accelerations (R_i beta / dt + g) from their mean:
  // how much the accelerometer's dynamic part says beyond a constant (uniform motion: noise only).
  double accel_excitation_m_s2 = 0.0;
};

// g_w: gravity in the frame of the poses (levelled: (0, 0, -g)); ba_prior_sigma_m_s2 > 0.
// kNotEnoughData with fewer than two usable intervals; kSingular if the system is degenerate.
Status alignment_observability(const Eigen::Quaterniond* q_w_b, const Preintegration* const* pre, int n,
                               const Eigen::Vector3d& g_w, double ba_prior_sigma_m_s2,
                               AlignmentObservability* out);

}  // namespace ums
