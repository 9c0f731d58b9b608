#pragma once
// The IMU residual of paper eq. (1) between keyframes i and j, with analytic Jacobians.
//
// Parameter blocks (docs/conventions.md): pose [p_w_b(3), q_w_b(x,y,z,w)] with tangent
// [dp, dtheta] (q <- q Exp(dtheta)); speed-bias [v_w_b(3), b_a(3), b_g(3)], Euclidean.
// With the first-order bias-corrected deltas alpha~, beta~, gamma~ (Preintegration::corrected at
// the biases of i) and g_w the gravity vector in the world (0, 0, -9.81):
//   r_p     = R_i^T (p_j - p_i - v_i dt - 1/2 g_w dt^2) - alpha~
//   r_theta = 2 vec(gamma~^-1 * q_i^-1 * q_j)        (sign chosen so that the scalar part is >= 0)
//   r_v     = R_i^T (v_j - v_i - g_w dt) - beta~
//   r_ba    = b_a,j - b_a,i,   r_bg = b_g,j - b_g,i
// Row order [p, theta, v, ba, bg]. The paper prints q^w_bk where its inverse is meant and mixes
// the sign of g between the p and v rows; the form above is the physically consistent one with
// g_w pointing down. Residual and Jacobians are returned whitened by U (U^T U = P^-1).

#include <Eigen/Core>

#include "core/common/status.hpp"
#include "core/imu/preintegration.hpp"

namespace ums {

class ImuResidual {
 public:
  static constexpr int kNumResiduals = 15;
  static constexpr int kPoseTangent = 6;
  static constexpr int kSpeedBiasSize = 9;
  // Row-major Jacobian blocks (Ceres layout), with respect to the tangent of each block.
  using JacobianPose = Eigen::Matrix<double, 15, 6, Eigen::RowMajor>;
  using JacobianSpeedBias = Eigen::Matrix<double, 15, 9, Eigen::RowMajor>;
  using Vector15 = Eigen::Matrix<double, 15, 1>;

  // Binds a preintegration (kept by pointer: it must outlive this object and is read at every
  // evaluate(), so a repropagation is seen, but then call update_whitening()) and the gravity
  // vector. kSingular when its covariance cannot be inverted (fewer than two samples).
  Status init(const Preintegration* preintegration, const Eigen::Vector3d& g_w);
  // Recomputes the whitening after the preintegration changed (repropagation). A covariance
  // equal, bit for bit, to the one of the last successful whitening keeps it: the window
  // re-binds every frame's factor each frame, and most preintegrations have not changed.
  Status update_whitening();

  // residual: 15 doubles. jacobians: each may be null; otherwise row-major 15x6 (pose_i),
  // 15x9 (speedbias_i), 15x6 (pose_j), 15x9 (speedbias_j). Returns false only if the residual
  // is not finite. Allocates nothing.
  bool evaluate(const double* pose_i, const double* speedbias_i, const double* pose_j,
                const double* speedbias_j, double* residual, double* d_r_d_pose_i,
                double* d_r_d_speedbias_i, double* d_r_d_pose_j, double* d_r_d_speedbias_j) const;

  // Unwhitened residual (for tests, diagnostics and chi-square gating by the caller).
  Vector15 raw_residual(const double* pose_i, const double* speedbias_i, const double* pose_j,
                        const double* speedbias_j) const;

  const Preintegration::Matrix15& sqrt_information() const { return sqrt_information_; }
  const Preintegration* preintegration() const { return pre_; }

 private:
  const Preintegration* pre_ = nullptr;
  Eigen::Vector3d g_w_ = Eigen::Vector3d(0.0, 0.0, -9.81);
  Preintegration::Matrix15 sqrt_information_ = Preintegration::Matrix15::Identity();
  Preintegration::Matrix15 whitened_covariance_ = Preintegration::Matrix15::Zero();  // its P, when whitened_
  bool whitened_ = false;
};

}  // namespace ums
