#pragma once
// Small residuals on the estimator's own states (no sensor model of their own):
//  - SpeedBiasPrior: a diagonal Gaussian on a speed-bias block [v, b_a, b_g] around a target,
//    per-row sigmas; rows with sigma <= 0 are left free (zero weight). Used for the bias prior at
//    initialization and for zero velocity at rest (v = 0).
//  - StillResidual: two poses coincide (p_j - p_i = 0, Log(q_i^-1 q_j) = 0), the zero-motion
//    constraint while the IMU says the rig is at rest; it holds the estimate still when still
//    (drift at rest is a common complaint about the parent VINS-Fusion, issue #11 / #36).

#include <Eigen/Core>

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

}  // namespace ums
