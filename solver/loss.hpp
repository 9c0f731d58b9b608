#pragma once
// Robust losses rho(s) of the squared residual norm s = |r|^2, and the correction that folds them
// into the Gauss-Newton system (Triggs et al., "Bundle adjustment - a modern synthesis", sec. 4.3;
// the same algebra as Ceres' Corrector, so costs and steps match it to round-off). The paper
// (eq. 4) puts a Huber loss on every visual residual.
//
// cost of one residual block = 0.5 * rho(s).

#include <cstdint>

namespace ums::solver {

enum class LossType : std::uint8_t { kTrivial = 0, kHuber, kCauchy };

struct RobustLoss {
  LossType type = LossType::kTrivial;
  double scale = 1.0;  // a: the residual norm (whitened units) where the loss leaves quadratic

  static RobustLoss trivial() { return {}; }
  static RobustLoss huber(double a) { return {LossType::kHuber, a}; }
  static RobustLoss cauchy(double a) { return {LossType::kCauchy, a}; }

  // rho[0] = rho(s), rho[1] = rho'(s), rho[2] = rho''(s).
  //   Huber:  s <= a^2: s;  else 2 a sqrt(s) - a^2
  //   Cauchy: a^2 log(1 + s / a^2)
  void evaluate(double s, double rho[3]) const;
};

// Scales residual r and Jacobian J (rows x cols, row stride) so that 0.5 |r'|^2 has the loss's
// gradient and its Gauss-Newton Hessian (Triggs correction; plain sqrt(rho') when rho'' <= 0, which
// is always the case for Huber and Cauchy).
class LossCorrector {
 public:
  LossCorrector(double sq_norm, const double rho[3]);
  // J must be corrected with the residual as it was before correct_residual().
  void correct_jacobian(int rows, int cols, int row_stride, const double* r, double* J) const {
    if (alpha_sq_norm_ == 0.0 && row_stride == cols) {
      // The common (Huber, Cauchy) case on contiguous storage: one scaling pass.
      for (int i = 0; i < rows * cols; ++i) J[i] *= sqrt_rho1_;
      return;
    }
    correct_jacobian_general(rows, cols, row_stride, r, J);
  }
  void correct_residual(int rows, double* r) const {
    for (int i = 0; i < rows; ++i) r[i] *= residual_scaling_;
  }

 private:
  void correct_jacobian_general(int rows, int cols, int row_stride, const double* r,
                                double* J) const;

  double sqrt_rho1_ = 1.0;
  double residual_scaling_ = 1.0;
  double alpha_sq_norm_ = 0.0;
};

}  // namespace ums::solver
