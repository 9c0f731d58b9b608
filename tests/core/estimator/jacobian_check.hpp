#pragma once
// Central-difference check of a solver::ResidualFunction's tangent Jacobians (test helper).

#include <cmath>
#include <vector>

#include <Eigen/Core>

#include "solver/manifold.hpp"
#include "solver/residual.hpp"

namespace ums::test {

struct BlockSpec {
  double* x;
  int ambient;
  bool pose;  // pose manifold (7 / 6) or Euclidean
};

// Largest |analytic - numeric| over all entries, relative to max(1, |numeric|).
inline double max_jacobian_error(const solver::ResidualFunction& f, const std::vector<BlockSpec>& blocks) {
  const int rows = f.num_residuals();
  std::vector<const double*> params;
  for (const BlockSpec& b : blocks) params.push_back(b.x);
  std::vector<std::vector<double>> jac(blocks.size());
  std::vector<solver::JacobianView> views(blocks.size());
  for (std::size_t k = 0; k < blocks.size(); ++k) {
    const int t = blocks[k].pose ? 6 : blocks[k].ambient;
    jac[k].assign(static_cast<std::size_t>(rows * t), 0.0);
    views[k] = {jac[k].data(), t};
  }
  std::vector<double> r0(static_cast<std::size_t>(rows));
  if (!f.evaluate(params.data(), r0.data(), views.data())) return 1e9;
  double worst = 0.0;
  const double h = 1e-6;
  for (std::size_t k = 0; k < blocks.size(); ++k) {
    const BlockSpec& b = blocks[k];
    const int t = b.pose ? 6 : b.ambient;
    std::vector<double> saved(b.x, b.x + b.ambient);
    for (int j = 0; j < t; ++j) {
      std::vector<double> rp(static_cast<std::size_t>(rows)), rm(static_cast<std::size_t>(rows));
      double d[9] = {};
      for (int side = 0; side < 2; ++side) {
        d[j] = side == 0 ? h : -h;
        if (b.pose) {
          solver::manifold_plus(solver::ManifoldType::kPose, 7, saved.data(), d, b.x);
        } else {
          for (int i = 0; i < b.ambient; ++i) b.x[i] = saved[static_cast<std::size_t>(i)] + d[i];
        }
        f.evaluate(params.data(), side == 0 ? rp.data() : rm.data(), nullptr);
      }
      std::copy(saved.begin(), saved.end(), b.x);
      for (int r = 0; r < rows; ++r) {
        const double num = (rp[static_cast<std::size_t>(r)] - rm[static_cast<std::size_t>(r)]) / (2 * h);
        const double ana = jac[k][static_cast<std::size_t>(r * t + j)];
        worst = std::max(worst, std::abs(ana - num) / std::max(1.0, std::abs(num)));
      }
    }
  }
  return worst;
}

}  // namespace ums::test
