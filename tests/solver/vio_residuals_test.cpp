#include "profiling/solver_bench/vio_residuals.hpp"

#include <catch2/catch.hpp>

#include "profiling/solver_bench/vio_window.hpp"

namespace ums::bench {
namespace {

struct BlockShape {
  solver::ManifoldType manifold;
  int ambient;
};

BlockShape shape_of(BlockKind k) {
  switch (k) {
    case BlockKind::kPose:
    case BlockKind::kExtrinsic: return {solver::ManifoldType::kPose, 7};
    case BlockKind::kSpeedBias: return {solver::ManifoldType::kEuclidean, 9};
    case BlockKind::kInverseDepth: return {solver::ManifoldType::kEuclidean, 1};
  }
  return {solver::ManifoldType::kEuclidean, 1};
}

// Largest |analytic - central difference| / (1 + |analytic|) over every Jacobian entry.
double jacobian_error(const ResidualDesc& r, VioWindow& w) {
  const int rows = r.fn->num_residuals();
  const double* params[4];
  double jac[4][15 * 9];
  solver::JacobianView views[4];
  for (int k = 0; k < r.num_blocks; ++k) {
    params[k] = w.data(r.blocks[k]);
    const BlockShape s = shape_of(r.blocks[k].kind);
    views[k] = {jac[k], solver::tangent_size(s.manifold, s.ambient)};
  }
  double res[15];
  REQUIRE(r.fn->evaluate(params, res, views));
  double worst = 0.0;
  for (int k = 0; k < r.num_blocks; ++k) {
    const BlockShape s = shape_of(r.blocks[k].kind);
    const int t = solver::tangent_size(s.manifold, s.ambient);
    for (int c = 0; c < t; ++c) {
      double plus[9], minus[9], d[9] = {};
      const double h = 1e-6;
      d[c] = h;
      solver::manifold_plus(s.manifold, s.ambient, params[k], d, plus);
      d[c] = -h;
      solver::manifold_plus(s.manifold, s.ambient, params[k], d, minus);
      const double* pp[4];
      double rp[15], rm[15];
      solver::JacobianView none[4];
      for (int q = 0; q < r.num_blocks; ++q) pp[q] = params[q];
      pp[k] = plus;
      REQUIRE(r.fn->evaluate(pp, rp, none));
      pp[k] = minus;
      REQUIRE(r.fn->evaluate(pp, rm, none));
      for (int i = 0; i < rows; ++i) {
        const double num = (rp[i] - rm[i]) / (2.0 * h);
        const double ana = jac[k][i * t + c];
        worst = std::max(worst, std::abs(num - ana) / (1.0 + std::abs(ana)));
      }
    }
  }
  return worst;
}

TEST_CASE("Reprojection, stereo and IMU-like Jacobians match central differences",
          "[solver][bench_residuals]") {
  WindowConfig cfg;
  cfg.frames = 5;
  cfg.landmarks = 15;
  cfg.max_obs = 5;
  auto w = make_vio_window(cfg);
  int checked[3] = {0, 0, 0};
  double worst[3] = {0.0, 0.0, 0.0};
  for (const ResidualDesc& r : w->residuals) {
    const int kind = r.fn->num_residuals() == 15 ? 2 : (r.num_blocks == 1 ? 1 : 0);
    worst[kind] = std::max(worst[kind], jacobian_error(r, *w));
    ++checked[kind];
  }
  INFO("reprojection " << worst[0] << " stereo " << worst[1] << " imu " << worst[2]);
  CHECK(checked[0] > 10);
  CHECK(checked[1] > 3);
  CHECK(checked[2] == 4);
  // Whitened units: reprojection Jacobians are ~300 per unit; 1e-6 relative is far below any
  // sign or term error.
  CHECK(worst[0] < 1e-6);
  CHECK(worst[1] < 1e-6);
  CHECK(worst[2] < 1e-5);
}

}  // namespace
}  // namespace ums::bench
