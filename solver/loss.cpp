#include "solver/loss.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

namespace ums::solver {

void RobustLoss::evaluate(double s, double rho[3]) const {
  switch (type) {
    case LossType::kTrivial:
      rho[0] = s;
      rho[1] = 1.0;
      rho[2] = 0.0;
      return;
    case LossType::kHuber: {
      const double b = scale * scale;
      if (s > b) {
        const double r = std::sqrt(s);
        rho[0] = 2.0 * scale * r - b;
        // Floor keeps sqrt(rho') > 0 for absurd outliers (same floor as Ceres).
        rho[1] = std::max(std::numeric_limits<double>::min(), scale / r);
        rho[2] = -rho[1] / (2.0 * s);
      } else {
        rho[0] = s;
        rho[1] = 1.0;
        rho[2] = 0.0;
      }
      return;
    }
    case LossType::kCauchy: {
      const double b = scale * scale;
      const double c = 1.0 / b;
      const double sum = 1.0 + s * c;
      const double inv = 1.0 / sum;
      rho[0] = b * std::log(sum);
      rho[1] = std::max(std::numeric_limits<double>::min(), inv);
      rho[2] = -c * inv * inv;
      return;
    }
  }
}

LossCorrector::LossCorrector(double sq_norm, const double rho[3]) {
  sqrt_rho1_ = std::sqrt(rho[1]);
  if (sq_norm == 0.0 || rho[2] <= 0.0) {
    residual_scaling_ = sqrt_rho1_;
    alpha_sq_norm_ = 0.0;
    return;
  }
  // Triggs: alpha solves 0.5 alpha^2 - alpha - rho'' / rho' * s = 0, the root in [0, 1).
  const double d = 1.0 + 2.0 * sq_norm * rho[2] / rho[1];
  const double alpha = 1.0 - std::sqrt(d);
  residual_scaling_ = sqrt_rho1_ / (1.0 - alpha);
  alpha_sq_norm_ = alpha / sq_norm;
}

void LossCorrector::correct_jacobian_general(int rows, int cols, int row_stride, const double* r,
                                             double* J) const {
  if (alpha_sq_norm_ == 0.0) {
    for (int i = 0; i < rows; ++i)
      for (int c = 0; c < cols; ++c) J[i * row_stride + c] *= sqrt_rho1_;
    return;
  }
  for (int c = 0; c < cols; ++c) {
    double rtj = 0.0;
    for (int i = 0; i < rows; ++i) rtj += r[i] * J[i * row_stride + c];
    for (int i = 0; i < rows; ++i)
      J[i * row_stride + c] = sqrt_rho1_ * (J[i * row_stride + c] - alpha_sq_norm_ * r[i] * rtj);
  }
}

}  // namespace ums::solver
