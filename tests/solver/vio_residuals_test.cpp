#include "profiling/solver_bench/vio_residuals.hpp"

#include <catch2/catch.hpp>

#include <cmath>

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

// 5 frames, 15 landmarks: every kind of residual, quick to check one by one.
WindowConfig small_window() {
  WindowConfig cfg;
  cfg.frames = 5;
  cfg.landmarks = 15;
  cfg.max_obs = 5;
  return cfg;
}

TEST_CASE("Reprojection, stereo and IMU-like Jacobians match central differences",
          "[solver][bench_residuals]") {
  const WindowConfig cfg = small_window();
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

// The products are shared through the cache: a residual must see any of the 21 doubles of its
// key (pose_i, pose_j, extrinsic) moved in place, and agree with a cache that never saw the old
// values; moved back, it must give the old residual again.
TEST_CASE("Reprojections sharing a pair's products follow every change of the values passed in",
          "[solver][bench_residuals]") {
  const WindowConfig cfg = small_window();
  auto w = make_vio_window(cfg);
  const Eigen::Matrix3d R[2] = {w->products->R_c0_ct(0), w->products->R_c0_ct(1)};
  const Eigen::Vector3d t[2] = {w->products->t_c0_ct(0), w->products->t_c0_ct(1)};
  int compared = 0, changed = 0;
  for (const ResidualDesc& d : w->residuals) {
    if (d.num_blocks != 4 || d.fn->num_residuals() != 2) continue;
    const auto* shared = static_cast<const ReprojectionResidual*>(d.fn);
    const double* x[4];
    for (int k = 0; k < 4; ++k) x[k] = w->data(d.blocks[k]);
    double r0[2], r1[2], fresh[2];
    solver::JacobianView none[4];
    REQUIRE(shared->evaluate(x, r0, none));
    for (int b = 0; b < 3; ++b) {
      for (int e = 0; e < 7; ++e) {
        double* moved = w->data(d.blocks[b]) + e;
        const double before = *moved;
        *moved = before * (1.0 + 1e-7) + 1e-9;  // far below the window's noise, far above rounding
        REQUIRE(shared->evaluate(x, r1, none));
        PairProductCache own(cfg.frames, R, t);
        ReprojectionResidual alone = shared->with_cache(&own);
        REQUIRE(alone.evaluate(x, fresh, none));
        CHECK(r1[0] == fresh[0]);
        CHECK(r1[1] == fresh[1]);
        changed += r1[0] != r0[0] || r1[1] != r0[1];
        *moved = before;
        REQUIRE(shared->evaluate(x, r1, none));
        CHECK(r1[0] == r0[0]);
        CHECK(r1[1] == r0[1]);
        ++compared;
      }
    }
  }
  CHECK(compared > 30 * 21);
  CHECK(changed > compared * 9 / 10);  // the moves reach the residuals: the test can tell
}

}  // namespace
}  // namespace ums::bench
