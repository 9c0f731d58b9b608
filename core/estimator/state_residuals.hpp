#pragma once
// Small residuals on the estimator's own states (no sensor model of their own):
//  - SpeedBiasPrior: a diagonal Gaussian on a speed-bias block [v, b_a, b_g] around a target,
//    per-row sigmas; rows with sigma <= 0 are left free (zero weight). Used for the bias prior at
//    initialization and for zero velocity at rest (v = 0).
//  - StillResidual: two poses coincide (p_j - p_i = 0, Log(q_i^-1 q_j) = 0), the zero-motion
//    constraint while the IMU says the rig is at rest; it holds the estimate still when still
//    (drift at rest is a common complaint about the parent VINS-Fusion, issue #11 / #36).
//  - PosePrior: a pose block around a target pose (p - p0, Log(q0^-1 q)) over sigmas in metres
//    and radians: the calibration's extrinsics when they float (estimate_extrinsic).
//  - RelativePosePrior: two pose blocks keep a relative pose T_a_b (R_a^T (p_b - p_a) - t_ab,
//    Log(q_ab^-1 q_a^-1 q_b)): the stereo pair's calibrated baseline while the extrinsics float.
//  - ScalarPrior: a 1-double block around a target, (x - x0) / sigma: the calibration's time
//    offset when it floats (estimate_td).
// Pose blocks are [p, q] with q perturbed on the right: q Exp(d).

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "solver/residual.hpp"

namespace ums {

class SpeedBiasPrior final : public solver::ResidualFunction {
 public:
  using Vector9 = Eigen::Matrix<double, 9, 1>;
  // sigma: m/s for v, m/s^2 for b_a, rad/s for b_g.
  void set(const Vector9& target, const Vector9& sigma);
  int num_residuals() const override { return 9; }
  bool evaluate(const double* const* x, double* r, const solver::JacobianView* jac) const override;

 private:
  Vector9 target_ = Vector9::Zero();
  Vector9 weight_ = Vector9::Zero();
};

class StillResidual final : public solver::ResidualFunction {
 public:
  void set(double sigma_m, double sigma_rad) { w_p_ = 1.0 / sigma_m; w_r_ = 1.0 / sigma_rad; }
  int num_residuals() const override { return 6; }
  bool evaluate(const double* const* x, double* r, const solver::JacobianView* jac) const override;

 private:
  double w_p_ = 1e3;
  double w_r_ = 1e3;
};

class PosePrior final : public solver::ResidualFunction {
 public:
  void set(const Eigen::Vector3d& p0, const Eigen::Quaterniond& q0, double sigma_m, double sigma_rad);
  int num_residuals() const override { return 6; }
  bool evaluate(const double* const* x, double* r, const solver::JacobianView* jac) const override;

 private:
  Eigen::Vector3d p0_ = Eigen::Vector3d::Zero();
  Eigen::Quaterniond q0_ = Eigen::Quaterniond::Identity();
  double w_p_ = 1.0, w_r_ = 1.0;
};

class RelativePosePrior final : public solver::ResidualFunction {
 public:
  // t_ab, q_ab: b in a's frame.
  void set(const Eigen::Vector3d& t_ab, const Eigen::Quaterniond& q_ab, double sigma_m, double sigma_rad);
  int num_residuals() const override { return 6; }
  bool evaluate(const double* const* x, double* r, const solver::JacobianView* jac) const override;

 private:
  Eigen::Vector3d t_ab_ = Eigen::Vector3d::Zero();
  Eigen::Quaterniond q_ab_ = Eigen::Quaterniond::Identity();
  double w_p_ = 1.0, w_r_ = 1.0;
};

class ScalarPrior final : public solver::ResidualFunction {
 public:
  void set(double x0, double sigma) {
    x0_ = x0;
    w_ = 1.0 / sigma;
  }
  int num_residuals() const override { return 1; }
  bool evaluate(const double* const* x, double* r, const solver::JacobianView* jac) const override;

 private:
  double x0_ = 0.0;
  double w_ = 1.0;
};

// x ~ x0 with sigma on each of a 3-double block (r = (x - x0) / sigma): the gyro scale's prior.
class Vector3Prior final : public solver::ResidualFunction {
 public:
  void set(const Eigen::Vector3d& x0, double sigma) {
    x0_ = x0;
    w_ = 1.0 / sigma;
  }
  int num_residuals() const override { return 3; }
  bool evaluate(const double* const* x, double* r, const solver::JacobianView* jac) const override;

 private:
  Eigen::Vector3d x0_ = Eigen::Vector3d::Zero();
  double w_ = 1.0;
};

}  // namespace ums
