#include "solver/problem.hpp"

#include <Eigen/Cholesky>
#include <catch2/catch.hpp>
#include <cmath>
#include <limits>
#include <memory>
#include <vector>

#include "profiling/alloc_counter.hpp"
#include "profiling/solver_bench/vio_window.hpp"

namespace ums::solver {
namespace {

using bench::BlockKind;
using bench::BlockRef;
using bench::VioWindow;
using bench::WindowConfig;

WindowConfig small_window(bool noise_free, bool prior) {
  WindowConfig cfg;
  cfg.frames = 5;
  cfg.landmarks = 40;
  cfg.max_obs = 5;
  cfg.noise_free = noise_free;
  cfg.with_prior = prior;
  cfg.seed = 7;
  return cfg;
}

// Block ids of add_to_problem's enumeration.
int block_id(const VioWindow& w, const BlockRef& b) {
  const int F = static_cast<int>(w.poses.size());
  switch (b.kind) {
    case BlockKind::kPose: return b.index;
    case BlockKind::kSpeedBias: return F + b.index;
    case BlockKind::kExtrinsic: return 2 * F;
    case BlockKind::kInverseDepth: return 2 * F + 1 + b.index;
  }
  return -1;
}
struct Shape {
  ManifoldType manifold;
  int ambient;
  int tangent;
};
Shape shape(const VioWindow& w, int id) {
  const int F = static_cast<int>(w.poses.size());
  if (id < F || id == 2 * F) return {ManifoldType::kPose, 7, 6};
  if (id < 2 * F) return {ManifoldType::kEuclidean, 9, 9};
  return {ManifoldType::kEuclidean, 1, 1};
}
double* block_data(VioWindow& w, int id) {
  const int F = static_cast<int>(w.poses.size());
  if (id < F) return w.poses[id].data();
  if (id < 2 * F) return w.speed_bias[id - F].data();
  if (id == 2 * F) return w.extrinsic.data();
  return &w.inv_depth[id - 2 * F - 1];
}
int num_ids(const VioWindow& w) { return 2 * static_cast<int>(w.poses.size()) + 1 + static_cast<int>(w.inv_depth.size()); }

// Snapshot of every block's ambient values, in id order.
std::vector<double> snapshot(VioWindow& w) {
  std::vector<double> s;
  for (int id = 0; id < num_ids(w); ++id) {
    const Shape sh = shape(w, id);
    const double* x = block_data(w, id);
    s.insert(s.end(), x, x + sh.ambient);
  }
  return s;
}
// Tangent difference after - before for every block (id order).
Eigen::VectorXd tangent_delta(VioWindow& w, const std::vector<double>& before) {
  std::vector<double> d;
  std::size_t o = 0;
  for (int id = 0; id < num_ids(w); ++id) {
    const Shape sh = shape(w, id);
    double t[9];
    manifold_minus(sh.manifold, sh.ambient, block_data(w, id), before.data() + o, t);
    d.insert(d.end(), t, t + sh.tangent);
    o += static_cast<std::size_t>(sh.ambient);
  }
  return Eigen::Map<Eigen::VectorXd>(d.data(), static_cast<Eigen::Index>(d.size()));
}

// Dense J (robust-corrected) and r of the whole window over all blocks (id order), built without
// the solver's accumulation code: the reference for the Schur path.
void dense_system(VioWindow& w, Eigen::MatrixXd* J, Eigen::VectorXd* r) {
  std::vector<int> offset(static_cast<std::size_t>(num_ids(w)));
  int dim = 0;
  for (int id = 0; id < num_ids(w); ++id) {
    offset[static_cast<std::size_t>(id)] = dim;
    dim += shape(w, id).tangent;
  }
  int rows = 0;
  for (const auto& rd : w.residuals) rows += rd.fn->num_residuals();
  if (w.prior) rows += w.prior->dim();
  J->setZero(rows, dim);
  r->setZero(rows);
  int row = 0;
  for (const auto& rd : w.residuals) {
    const int m = rd.fn->num_residuals();
    const double* params[4];
    double jac[4][15 * 9];
    JacobianView views[4];
    for (int k = 0; k < rd.num_blocks; ++k) {
      const int id = block_id(w, rd.blocks[k]);
      params[k] = block_data(w, id);
      views[k] = {jac[k], shape(w, id).tangent};
    }
    double res[15];
    REQUIRE(rd.fn->evaluate(params, res, views));
    double sq = 0.0;
    for (int i = 0; i < m; ++i) sq += res[i] * res[i];
    double rho[3];
    rd.loss.evaluate(sq, rho);
    LossCorrector corr(sq, rho);
    for (int k = 0; k < rd.num_blocks; ++k) {
      const int id = block_id(w, rd.blocks[k]);
      const int t = shape(w, id).tangent;
      corr.correct_jacobian(m, t, t, res, jac[k]);
      for (int i = 0; i < m; ++i)
        for (int c = 0; c < t; ++c) (*J)(row + i, offset[static_cast<std::size_t>(id)] + c) = jac[k][i * t + c];
    }
    corr.correct_residual(m, res);
    for (int i = 0; i < m; ++i) (*r)(row + i) = res[i];
    row += m;
  }
  if (w.prior) {
    const int n = w.prior->dim();
    std::vector<const double*> xs;
    std::vector<std::vector<double>> jb(w.prior_blocks.size());
    std::vector<JacobianView> views;
    for (std::size_t k = 0; k < w.prior_blocks.size(); ++k) {
      const int id = block_id(w, w.prior_blocks[k]);
      xs.push_back(block_data(w, id));
      jb[k].resize(static_cast<std::size_t>(n * shape(w, id).tangent));
      views.push_back({jb[k].data(), shape(w, id).tangent});
    }
    std::vector<double> res(static_cast<std::size_t>(n));
    REQUIRE(w.prior->evaluate(xs.data(), res.data(), views.data()));
    for (std::size_t k = 0; k < w.prior_blocks.size(); ++k) {
      const int id = block_id(w, w.prior_blocks[k]);
      const int t = shape(w, id).tangent;
      for (int i = 0; i < n; ++i)
        for (int c = 0; c < t; ++c)
          (*J)(row + i, offset[static_cast<std::size_t>(id)] + c) = jb[k][static_cast<std::size_t>(i * t + c)];
    }
    for (int i = 0; i < n; ++i) (*r)(row + i) = res[static_cast<std::size_t>(i)];
  }
}

SolverOptions one_step(Method method) {
  SolverOptions o;
  o.method = method;
  o.max_iterations = 1;
  o.function_tolerance = 0.0;
  o.parameter_tolerance = 0.0;
  o.gradient_tolerance = 0.0;
  return o;
}

TEST_CASE("LM reaches the known optimum of a noise-free window", "[solver][problem]") {
  auto w = bench::make_vio_window(small_window(true, true));
  auto problem = std::make_unique<Problem>();
  REQUIRE(bench::add_to_problem(*w, *problem) == SolverStatus::kOk);
  SolverOptions opt;
  opt.function_tolerance = 1e-12;
  SolverSummary sum;
  const SolverStatus st = problem->solve(opt, &sum);
  INFO("status " << to_string(st) << " iterations " << sum.iterations << " cost "
                 << sum.initial_cost << " -> " << sum.final_cost);
  CHECK(usable(st));
  CHECK(sum.initial_cost > 100.0);
  CHECK(sum.final_cost < 1e-12);
  double pos_err = 0.0;
  double rho_err = 0.0;
  for (std::size_t i = 0; i < w->poses.size(); ++i)
    for (int k = 0; k < 3; ++k) pos_err = std::max(pos_err, std::abs(w->poses[i][static_cast<std::size_t>(k)] - w->poses_true[i][static_cast<std::size_t>(k)]));
  for (std::size_t l = 0; l < w->inv_depth.size(); ++l)
    rho_err = std::max(rho_err, std::abs(w->inv_depth[l] / w->inv_depth_true[l] - 1.0));
  CHECK(pos_err < 1e-7);  // m
  CHECK(rho_err < 1e-6);  // relative
}

TEST_CASE("Gauge fixed by a constant first pose (no prior): converges to the truth",
          "[solver][problem]") {
  auto w = bench::make_vio_window(small_window(true, false));
  auto problem = std::make_unique<Problem>();
  // The fixed first pose takes its true value; every other block starts perturbed.
  w->poses[0] = w->poses_true[0];
  REQUIRE(bench::add_to_problem(*w, *problem) == SolverStatus::kOk);
  REQUIRE(problem->set_constant(0, true) == SolverStatus::kOk);
  for (const Method m : {Method::kLevenbergMarquardt, Method::kGaussNewton}) {
    w->reset();
    w->poses[0] = w->poses_true[0];
    SolverOptions opt;
    opt.method = m;
    opt.function_tolerance = 1e-12;
    SolverSummary sum;
    const SolverStatus st = problem->solve(opt, &sum);
    INFO("method " << static_cast<int>(m) << " status " << to_string(st) << " cost " << sum.final_cost);
    CHECK(usable(st));
    CHECK(problem->reduced_offset(0) == -1);
    CHECK(problem->reduced_dim() == 4 * 6 + 5 * 9 + 6);
    CHECK(sum.final_cost < 1e-12);
    double yaw_err = 0.0;
    for (std::size_t i = 0; i < w->poses.size(); ++i) {
      const Eigen::Quaterniond q(w->poses[i][6], w->poses[i][3], w->poses[i][4], w->poses[i][5]);
      const Eigen::Quaterniond qt(w->poses_true[i][6], w->poses_true[i][3], w->poses_true[i][4],
                                  w->poses_true[i][5]);
      yaw_err = std::max(yaw_err, q.angularDistance(qt));
    }
    CHECK(yaw_err < 1e-8);  // rad
  }
}

// A 2-D point seen by 20 measurements, 5 of them gross outliers.
class PointResidual final : public ResidualFunction {
 public:
  PointResidual(double mx, double my) : m_{mx, my} {}
  int num_residuals() const override { return 2; }
  bool evaluate(const double* const* x, double* r, const JacobianView* jac) const override {
    r[0] = (x[0][0] - m_[0]) / 0.1;  // sigma 0.1 m
    r[1] = (x[0][1] - m_[1]) / 0.1;
    if (jac[0].wanted()) jacobian_map<2, 2>(jac[0]) = 10.0 * Eigen::Matrix2d::Identity();
    return true;
  }

 private:
  double m_[2];
};

TEST_CASE("Reduced ordering: blocks seen by landmarks first, in declaration order, the IMU chain newest first",
          "[solver][problem]") {
  // add_to_problem declares poses, then speed-biases, then the extrinsic: the extrinsic (observed
  // through every reprojection) must come right after the variable poses, so a landmark's
  // couplings form contiguous row segments. The speed-biases (IMU only here) follow, by the first
  // pose row their IMU terms reach, latest first: speed-bias i meets poses i-1..i+1 (pose 0 is
  // constant), so 4, 3, then 2, 1, 0 (all reaching pose 1, the later declared first).
  auto w = bench::make_vio_window(small_window(true, false));
  auto problem = std::make_unique<Problem>();
  w->poses[0] = w->poses_true[0];
  REQUIRE(bench::add_to_problem(*w, *problem) == SolverStatus::kOk);
  REQUIRE(problem->set_constant(0, true) == SolverStatus::kOk);
  SolverSummary sum;
  REQUIRE(usable(problem->solve(one_step(Method::kGaussNewton), &sum)));
  const int F = static_cast<int>(w->poses.size());
  REQUIRE(F == 5);
  CHECK(problem->reduced_offset(0) == -1);
  for (int i = 1; i < F; ++i) CHECK(problem->reduced_offset(i) == 6 * (i - 1));
  CHECK(problem->reduced_offset(2 * F) == 6 * (F - 1));  // extrinsic
  for (int i = 0; i < F; ++i) CHECK(problem->reduced_offset(F + i) == 6 * F + 9 * (F - 1 - i));
  CHECK(problem->reduced_dim() == 6 * F + 9 * F);
  CHECK(problem->reduced_offset(2 * F + 1) == -1);  // a landmark is eliminated
}

TEST_CASE("Huber and Cauchy reject planted outliers that pull least squares away",
          "[solver][problem]") {
  bench::Rng rng(3);
  std::vector<PointResidual> meas;
  for (int i = 0; i < 20; ++i) {
    const bool outlier = i % 4 == 0;  // 5 of 20
    meas.emplace_back(1.0 + (outlier ? 5.0 : 0.1 * rng.normal()), -2.0 + (outlier ? 4.0 : 0.1 * rng.normal()));
  }
  auto problem = std::make_unique<Problem>();
  double err[3] = {};
  double cost[3] = {};
  const RobustLoss losses[3] = {RobustLoss::trivial(), RobustLoss::huber(1.0), RobustLoss::cauchy(1.0)};
  for (int k = 0; k < 3; ++k) {
    problem->clear();
    double x[2] = {0.0, 0.0};
    BlockId id = 0;
    REQUIRE(problem->add_euclidean_block(x, 2, &id) == SolverStatus::kOk);
    for (const auto& m : meas) REQUIRE(problem->add_residual(&m, losses[k], {id}) == SolverStatus::kOk);
    SolverOptions opt;
    opt.function_tolerance = 1e-14;
    opt.parameter_tolerance = 1e-14;
    SolverSummary sum;
    REQUIRE(usable(problem->solve(opt, &sum)));
    err[k] = std::hypot(x[0] - 1.0, x[1] + 2.0);
    cost[k] = sum.final_cost;
    // The reported cost is 0.5 * sum rho(|r|^2), recomputed here independently.
    double expect = 0.0;
    for (const auto& m : meas) {
      const double* p[1] = {x};
      double r[2];
      JacobianView none[1];
      m.evaluate(p, r, none);
      double rho[3];
      losses[k].evaluate(r[0] * r[0] + r[1] * r[1], rho);
      expect += 0.5 * rho[0];
    }
    CHECK(cost[k] == Approx(expect).epsilon(1e-12));
  }
  INFO("error trivial " << err[0] << " huber " << err[1] << " cauchy " << err[2] << " m");
  CHECK(err[0] > 1.0);   // least squares is dragged about 1.6 m away
  CHECK(err[1] < 0.15);  // Huber: bounded influence
  CHECK(err[2] < 0.06);  // Cauchy: outliers nearly ignored
}

// Steps with the speed-bias chain eliminated first (envelope Cholesky, then a dense LLT of the
// pose/extrinsic rows) at 5 and 11 frames, against a dense solve of the full system.
void check_schur_steps(const WindowConfig& cfg) {
  auto w = bench::make_vio_window(cfg);
  auto problem = std::make_unique<Problem>();
  REQUIRE(bench::add_to_problem(*w, *problem) == SolverStatus::kOk);
  Eigen::MatrixXd J;
  Eigen::VectorXd r;
  dense_system(*w, &J, &r);
  const Eigen::MatrixXd H = J.transpose() * J;
  const Eigen::VectorXd g = J.transpose() * r;

  SECTION("Gauss-Newton step") {
    const Eigen::VectorXd expected = -H.ldlt().solve(g);
    const std::vector<double> before = snapshot(*w);
    SolverSummary sum;
    REQUIRE(usable(problem->solve(one_step(Method::kGaussNewton), &sum)));
    REQUIRE(sum.successful_steps == 1);
    const Eigen::VectorXd got = tangent_delta(*w, before);
    const double rel = (got - expected).norm() / expected.norm();
    INFO("relative difference " << rel << " |step| " << expected.norm());
    CHECK(rel < 1e-8);
  }
  SECTION("Levenberg-Marquardt step with Ceres' Jacobi-scaled Marquardt diagonal") {
    Eigen::MatrixXd Hd = H;
    for (int i = 0; i < H.rows(); ++i) {
      const double s = 1.0 / (1.0 + std::sqrt(H(i, i)));
      Hd(i, i) += std::clamp(s * s * H(i, i), 1e-6, 1e32) / (s * s) / 1e4;
    }
    const Eigen::VectorXd expected = -Hd.ldlt().solve(g);
    const std::vector<double> before = snapshot(*w);
    SolverSummary sum;
    REQUIRE(usable(problem->solve(one_step(Method::kLevenbergMarquardt), &sum)));
    REQUIRE(sum.successful_steps == 1);
    const Eigen::VectorXd got = tangent_delta(*w, before);
    const double rel = (got - expected).norm() / expected.norm();
    INFO("relative difference " << rel);
    CHECK(rel < 1e-8);
  }
}

TEST_CASE("Schur-complement steps equal dense solves of the full system", "[solver][problem]") {
  check_schur_steps(small_window(false, true));
}

TEST_CASE("Speed-bias chain eliminated before the dense LLT: steps equal dense solves",
          "[solver][problem]") {
  WindowConfig cfg = small_window(false, true);
  cfg.frames = 11;
  cfg.landmarks = 60;
  cfg.max_obs = 8;
  check_schur_steps(cfg);
}

namespace {

// Marginalizes frame 0 and its landmarks, checks the prior's blocks, then that one Gauss-Newton
// step of (remaining residuals + prior) equals the full problem's step on every kept block.
void check_marginalization(bool with_prior, int expected_blocks, int expected_dim) {
  // Without an old prior the full problem has a gauge freedom (Gauss-Newton cannot step): then
  // only the prior's blocks and information are checked.
  auto w = bench::make_vio_window(small_window(false, with_prior));
  auto full = std::make_unique<Problem>();
  REQUIRE(bench::add_to_problem(*w, *full) == SolverStatus::kOk);
  const std::vector<double> x0 = snapshot(*w);

  // Blocks to drop: frame 0 (pose, speed-bias) and the landmarks it hosts.
  const int F = static_cast<int>(w->poses.size());
  std::vector<BlockId> marg = {0, F};
  for (std::size_t l = 0; l < w->host.size(); ++l)
    if (w->host[l] == 0) marg.push_back(2 * F + 1 + static_cast<int>(l));
  REQUIRE(marg.size() > 3);
  auto prior = std::make_unique<MarginalPrior>();
  REQUIRE(full->marginalize(marg.data(), static_cast<int>(marg.size()), prior.get()) == SolverStatus::kOk);
  CHECK(prior->num_blocks() == expected_blocks);
  CHECK(prior->dim() == expected_dim);
  for (int i = 0; i < prior->num_blocks(); ++i) {
    const PriorBlock& pb = prior->block(i);
    const double info = prior->information().block(pb.offset, pb.offset, pb.tangent_size, pb.tangent_size).trace();
    INFO("prior block " << i << " (source " << pb.source_id << ")");
    CHECK(info > 0.0);
  }
  if (!with_prior) return;

  // Full problem, one Gauss-Newton step from x0.
  SolverSummary sum;
  REQUIRE(usable(full->solve(one_step(Method::kGaussNewton), &sum)));
  const Eigen::VectorXd d_full = tangent_delta(*w, x0);

  // Reduced problem: residuals not touching the dropped blocks + the new prior.
  w->reset();
  auto reduced = std::make_unique<Problem>();
  for (int id = 0; id < num_ids(*w); ++id) {
    BlockId got = 0;
    const Shape sh = shape(*w, id);
    REQUIRE(reduced->add_parameter_block(block_data(*w, id), sh.ambient, sh.manifold,
                                         id > 2 * F, &got) == SolverStatus::kOk);
  }
  for (BlockId id : marg) REQUIRE(reduced->set_constant(id, true) == SolverStatus::kOk);
  for (const auto& rd : w->residuals) {
    BlockId ids[4];
    bool dropped = false;
    for (int k = 0; k < rd.num_blocks; ++k) {
      ids[k] = block_id(*w, rd.blocks[k]);
      for (BlockId m : marg) dropped = dropped || m == ids[k];
    }
    if (!dropped) REQUIRE(reduced->add_residual(rd.fn, rd.loss, ids, rd.num_blocks) == SolverStatus::kOk);
  }
  BlockId prior_ids[capacity::kMaxReducedBlocks];
  for (int i = 0; i < prior->num_blocks(); ++i) prior_ids[i] = prior->block(i).source_id;
  REQUIRE(reduced->add_prior(prior.get(), prior_ids) == SolverStatus::kOk);
  REQUIRE(usable(reduced->solve(one_step(Method::kGaussNewton), &sum)));
  const Eigen::VectorXd d_red = tangent_delta(*w, x0);

  // Compare every kept (non-marginalized) block.
  double worst = 0.0, scale = 0.0;
  int o = 0;
  for (int id = 0; id < num_ids(*w); ++id) {
    const int t = shape(*w, id).tangent;
    bool dropped = false;
    for (BlockId m : marg) dropped = dropped || m == id;
    if (!dropped) {
      worst = std::max(worst, (d_full.segment(o, t) - d_red.segment(o, t)).lpNorm<Eigen::Infinity>());
      scale = std::max(scale, d_full.segment(o, t).lpNorm<Eigen::Infinity>());
    }
    o += t;
  }
  INFO("max |step difference| " << worst << " max |step| " << scale);
  CHECK(scale > 1e-3);
  CHECK(worst <= 1e-9 * scale);
}

}  // namespace

TEST_CASE("Marginalization gives the same step as the full problem's reduced system",
          "[solver][problem][marginalization]") {
  // Kept: poses 1..4 (IMU 0-1, landmarks, old prior), speed-bias 1 (IMU), extrinsic, and the
  // speed-biases 2..4 are untouched, so not in the prior.
  check_marginalization(true, 4 + 1 + 1, 4 * 6 + 9 + 6);
}

TEST_CASE("Marginalization without an old prior keeps the poses reached only by reprojections",
          "[solver][problem][marginalization]") {
  // No old prior: poses 2..4 are coupled to frame 0 only through its landmarks' 2-row
  // reprojection residuals (the fast accumulation path); they must be in the new prior.
  check_marginalization(false, 4 + 1 + 1, 4 * 6 + 9 + 6);
}

TEST_CASE("NaN and Inf inputs are rejected with a status, values untouched", "[solver][problem]") {
  auto w = bench::make_vio_window(small_window(false, true));
  auto problem = std::make_unique<Problem>();
  double bad[9] = {0, 0, 0, 0, 0, 0, 0, 0, std::numeric_limits<double>::quiet_NaN()};
  BlockId id = 0;
  CHECK(problem->add_euclidean_block(bad, 9, &id) == SolverStatus::kInvalidInput);
  CHECK(id == kInvalidBlock);
  bad[8] = std::numeric_limits<double>::infinity();
  CHECK(problem->add_landmark_block(bad + 8, 1, &id) == SolverStatus::kInvalidInput);

  REQUIRE(bench::add_to_problem(*w, *problem) == SolverStatus::kOk);
  // A value that became NaN after set-up (e.g. a broken propagation): solve refuses.
  w->speed_bias[2][4] = std::numeric_limits<double>::quiet_NaN();
  const std::vector<double> before = snapshot(*w);
  SolverSummary sum;
  CHECK(problem->solve(SolverOptions{}, &sum) == SolverStatus::kInvalidInput);
  double c = 0.0;
  CHECK(problem->evaluate_cost(&c) == SolverStatus::kInvalidInput);
  // An infinite inverse depth makes residuals non-finite: refused too.
  w->reset();
  w->inv_depth[3] = std::numeric_limits<double>::infinity();
  CHECK(problem->solve(SolverOptions{}, &sum) == SolverStatus::kInvalidInput);
  CHECK(std::isinf(w->inv_depth[3]));
  CHECK(w->poses[1] == w->poses0[1]);  // nothing moved
  // Bad options are refused as well.
  w->reset();
  SolverOptions bad_opt;
  bad_opt.min_lm_diagonal = -1.0;
  CHECK(problem->solve(bad_opt, &sum) == SolverStatus::kInvalidInput);
  CHECK(usable(problem->solve(SolverOptions{}, &sum)));
}

TEST_CASE("Iteration and time bounds stop the solve with their status", "[solver][problem]") {
  auto w = bench::make_vio_window(small_window(false, true));
  auto problem = std::make_unique<Problem>();
  REQUIRE(bench::add_to_problem(*w, *problem) == SolverStatus::kOk);
  SolverOptions opt;
  opt.max_iterations = 2;
  opt.function_tolerance = 0.0;
  SolverSummary sum;
  CHECK(problem->solve(opt, &sum) == SolverStatus::kMaxIterations);
  CHECK(sum.iterations == 2);
  CHECK(sum.final_cost < sum.initial_cost);
  // The values returned are the last accepted step's, and the reported cost is theirs; the
  // Jacobians at that point are not needed, so only the first step relinearized.
  double cost_now = 0.0;
  REQUIRE(problem->evaluate_cost(&cost_now) == SolverStatus::kOk);
  CHECK(cost_now == Approx(sum.final_cost).epsilon(1e-12));
  CHECK(sum.linearizations == 1 + std::min(sum.successful_steps, 1));
  w->reset();
  opt.max_iterations = 100;
  opt.max_time_s = 1e-9;  // s: exhausted before the first step
  CHECK(problem->solve(opt, &sum) == SolverStatus::kTimeBudget);
  CHECK(sum.iterations == 0);
  CHECK(sum.final_cost == sum.initial_cost);
}

// r = exp(x_seen) - 5, where x_seen is the block's value as copied by the evaluation callback: the
// solve only reaches x = ln 5 if the callback runs before every evaluation pass.
class SeenValue final : public EvaluationCallback {
 public:
  explicit SeenValue(const double* x) : x_(x) {}
  void prepare_for_evaluation() override {
    seen = *x_;
    ++calls;
  }
  double seen = 0.0;
  int calls = 0;

 private:
  const double* x_;
};

class ExpFromSeen final : public ResidualFunction {
 public:
  explicit ExpFromSeen(const SeenValue* v) : v_(v) {}
  int num_residuals() const override { return 1; }
  bool evaluate(const double* const*, double* r, const JacobianView* j) const override {
    r[0] = std::exp(v_->seen) - 5.0;
    if (j != nullptr && j[0].wanted()) j[0].data[0] = std::exp(v_->seen);
    return true;
  }

 private:
  const SeenValue* v_;
};

TEST_CASE("The evaluation callback runs before every pass of solve, cost and marginalization",
          "[solver][problem]") {
  double x = 0.0;
  SeenValue seen(&x);
  ExpFromSeen residual(&seen);
  auto problem = std::make_unique<Problem>();
  problem->set_evaluation_callback(&seen);
  BlockId id = kInvalidBlock;
  REQUIRE(problem->add_euclidean_block(&x, 1, &id) == SolverStatus::kOk);
  REQUIRE(problem->add_residual(&residual, RobustLoss::trivial(), {id}) == SolverStatus::kOk);
  SolverOptions opt;
  opt.function_tolerance = 1e-12;
  SolverSummary sum;
  REQUIRE(usable(problem->solve(opt, &sum)));
  CHECK(std::abs(x - std::log(5.0)) < 1e-6);
  // One per sweep over the residuals (linearizations, candidates' costs) and one for the cost of
  // the residuals over constant blocks.
  CHECK(seen.calls == sum.residual_passes + 1);
  CHECK(sum.residual_passes >= sum.linearizations);
  x = 1.0;
  const int before = seen.calls;
  double cost = 0.0;
  REQUIRE(problem->evaluate_cost(&cost) == SolverStatus::kOk);
  CHECK(seen.calls > before);
  CHECK(cost == Approx(0.5 * (std::exp(1.0) - 5.0) * (std::exp(1.0) - 5.0)).epsilon(1e-12));
  x = 2.0;
  auto prior = std::make_unique<MarginalPrior>();
  const int before_marg = seen.calls;
  problem->marginalize(&id, 1, prior.get());
  CHECK(seen.calls > before_marg);
  CHECK(seen.seen == 2.0);
}

TEST_CASE("Solve, cost evaluation and marginalization allocate nothing after set-up",
          "[solver][problem][alloc]") {
  WindowConfig cfg;
  cfg.frames = 11;
  cfg.landmarks = 120;
  auto w = bench::make_vio_window(cfg);
  auto problem = std::make_unique<Problem>();
  auto prior = std::make_unique<MarginalPrior>();
  REQUIRE(bench::add_to_problem(*w, *problem) == SolverStatus::kOk);
  std::vector<BlockId> marg = {0, 11};
  for (std::size_t l = 0; l < w->host.size(); ++l)
    if (w->host[l] == 0) marg.push_back(23 + static_cast<int>(l));
  SolverOptions opt;
  opt.max_iterations = 10;
  SolverSummary sum;
  double cost = 0.0;
  AllocScope scope;
  const SolverStatus st = problem->solve(opt, &sum);
  const SolverStatus sc = problem->evaluate_cost(&cost);
  const SolverStatus sm = problem->marginalize(marg.data(), static_cast<int>(marg.size()), prior.get());
  const auto allocations = scope.allocations();
  CHECK(usable(st));
  CHECK(sc == SolverStatus::kOk);
  CHECK(sm == SolverStatus::kOk);
  CHECK(cost == Approx(sum.final_cost).epsilon(1e-12));
  CHECK(sum.iterations >= 2);
  if (alloc_counter_available()) CHECK(allocations == 0);
}

}  // namespace
}  // namespace ums::solver

namespace ums::solver {
namespace {

// rows x cols standard normal draws, row by row.
Eigen::MatrixXd random_matrix(bench::Rng& rng, int rows, int cols) {
  Eigen::MatrixXd m(rows, cols);
  for (int i = 0; i < rows; ++i)
    for (int j = 0; j < cols; ++j) m(i, j) = rng.normal();
  return m;
}

// r = A x_a + B x_b + c (affine): one Gauss-Newton step lands on the least-squares solution. With
// bend != 0, r = A x_a + u + c + bend u^2 (u = B x_b, elementwise square): mildly nonlinear in x_b.
class AffineResidual final : public ResidualFunction {
 public:
  AffineResidual(const Eigen::MatrixXd& A, const Eigen::MatrixXd& B, const Eigen::VectorXd& c, double bend = 0.0)
      : A_(A), B_(B), c_(c), bend_(bend) {}
  int num_residuals() const override { return static_cast<int>(c_.size()); }
  bool evaluate(const double* const* x, double* r, const JacobianView* jac) const override {
    const Eigen::Map<const Eigen::VectorXd> xa(x[0], A_.cols()), xb(x[1], B_.cols());
    Eigen::MatrixXd JB = B_;
    if (bend_ == 0.0) {
      Eigen::Map<Eigen::VectorXd>(r, c_.size()) = A_ * xa + B_ * xb + c_;
    } else {
      const Eigen::VectorXd u = B_ * xb;
      Eigen::Map<Eigen::VectorXd>(r, c_.size()) = A_ * xa + u + c_ + bend_ * u.cwiseProduct(u);
      JB += 2.0 * bend_ * u.asDiagonal() * B_;
    }
    for (int k = 0; k < 2; ++k) {
      if (!jac[k].wanted()) continue;
      const Eigen::MatrixXd& M = k == 0 ? A_ : JB;
      for (int i = 0; i < M.rows(); ++i)
        for (int j = 0; j < M.cols(); ++j) jac[k].data[i * jac[k].row_stride + j] = M(i, j);
    }
    return true;
  }

 private:
  Eigen::MatrixXd A_, B_;
  Eigen::VectorXd c_;
  double bend_ = 0.0;
};

// Landmarks of lm_dim[l] dofs (1: the dense rows of problem_solve.cpp's eliminate_all; 2 or 3:
// eliminated alone, ending the chunk of 1-dof rows before them) over reduced blocks of the given
// sizes, each landmark seen by a random subset of them (gaps between its segments): one
// Gauss-Newton step against a dense solve of the full system.
void check_dense_schur(const std::vector<int>& red_size, const std::vector<int>& lm_dim, std::uint32_t seed) {
  bench::Rng rng(seed);
  auto randm = [&](int r, int c) { return random_matrix(rng, r, c); };
  const int nb = static_cast<int>(red_size.size());
  const int n_lm = static_cast<int>(lm_dim.size());
  std::vector<int> col(static_cast<std::size_t>(nb), 0), lm_col(static_cast<std::size_t>(n_lm), 0);
  int dim_red = 0;
  for (int k = 0; k < nb; ++k) {
    col[static_cast<std::size_t>(k)] = dim_red;
    dim_red += red_size[static_cast<std::size_t>(k)];
  }
  int dim = dim_red;
  for (int l = 0; l < n_lm; ++l) {
    lm_col[static_cast<std::size_t>(l)] = dim;
    dim += lm_dim[static_cast<std::size_t>(l)];
  }
  std::vector<std::vector<double>> x_red(static_cast<std::size_t>(nb)), x_lm(static_cast<std::size_t>(n_lm));
  auto problem = std::make_unique<Problem>();
  std::vector<BlockId> red_id(static_cast<std::size_t>(nb)), lm_id(static_cast<std::size_t>(n_lm));
  for (int k = 0; k < nb; ++k) {
    x_red[static_cast<std::size_t>(k)].assign(static_cast<std::size_t>(red_size[static_cast<std::size_t>(k)]), 0.0);
    REQUIRE(problem->add_euclidean_block(x_red[static_cast<std::size_t>(k)].data(), red_size[static_cast<std::size_t>(k)],
                                         &red_id[static_cast<std::size_t>(k)]) == SolverStatus::kOk);
  }
  for (int l = 0; l < n_lm; ++l) {
    x_lm[static_cast<std::size_t>(l)].assign(static_cast<std::size_t>(lm_dim[static_cast<std::size_t>(l)]), 0.0);
    REQUIRE(problem->add_landmark_block(x_lm[static_cast<std::size_t>(l)].data(), lm_dim[static_cast<std::size_t>(l)],
                                        &lm_id[static_cast<std::size_t>(l)]) == SolverStatus::kOk);
  }
  std::vector<std::unique_ptr<AffineResidual>> res;
  std::vector<Eigen::MatrixXd> Jrows;
  std::vector<Eigen::VectorXd> rrows;
  for (int l = 0; l < n_lm; ++l) {
    const int e = lm_dim[static_cast<std::size_t>(l)];
    int seen = 0;
    for (int k = 0; k < nb; ++k) {
      // Each block with probability 0.6, at least two per landmark (a 3-dof one: three, so
      // that its 3 x 3 block is invertible).
      const int need = std::max(2, e);
      if (rng.normal() < -0.25 && !(k >= nb - need && seen < need)) continue;
      ++seen;
      const int t = red_size[static_cast<std::size_t>(k)];
      const Eigen::MatrixXd A = randm(2, t), B = randm(2, e);
      Eigen::VectorXd c(2);
      c << rng.normal(), rng.normal();
      res.push_back(std::make_unique<AffineResidual>(A, B, c));
      REQUIRE(problem->add_residual(res.back().get(), RobustLoss::trivial(),
                                    {red_id[static_cast<std::size_t>(k)], lm_id[static_cast<std::size_t>(l)]}) == SolverStatus::kOk);
      Eigen::MatrixXd J = Eigen::MatrixXd::Zero(2, dim);
      J.block(0, col[static_cast<std::size_t>(k)], 2, t) = A;
      J.block(0, lm_col[static_cast<std::size_t>(l)], 2, e) = B;
      Jrows.push_back(J);
      rrows.push_back(c);
    }
  }
  Eigen::MatrixXd Jd(2 * static_cast<int>(Jrows.size()), dim);
  Eigen::VectorXd rd(Jd.rows());
  for (std::size_t i = 0; i < Jrows.size(); ++i) {
    Jd.middleRows(2 * static_cast<int>(i), 2) = Jrows[i];
    rd.segment(2 * static_cast<int>(i), 2) = rrows[i];
  }
  const Eigen::VectorXd expected = -(Jd.transpose() * Jd).ldlt().solve(Jd.transpose() * rd);
  SolverSummary sum;
  REQUIRE(usable(problem->solve(one_step(Method::kGaussNewton), &sum)));
  double worst = 0.0;
  for (int k = 0; k < nb; ++k)
    for (int i = 0; i < red_size[static_cast<std::size_t>(k)]; ++i)
      worst = std::max(worst, std::abs(x_red[static_cast<std::size_t>(k)][static_cast<std::size_t>(i)] -
                                       expected[col[static_cast<std::size_t>(k)] + i]));
  for (int l = 0; l < n_lm; ++l)
    for (int i = 0; i < lm_dim[static_cast<std::size_t>(l)]; ++i)
      worst = std::max(worst, std::abs(x_lm[static_cast<std::size_t>(l)][static_cast<std::size_t>(i)] -
                                       expected[lm_col[static_cast<std::size_t>(l)] + i]));
  INFO("front rows " << dim_red << ", landmarks " << n_lm << ": max |x - x_dense| " << worst);
  CHECK(expected.lpNorm<Eigen::Infinity>() > 1e-3);
  CHECK(worst < 1e-10 * (1.0 + expected.lpNorm<Eigen::Infinity>()));
}

std::vector<int> ones(int n) { return std::vector<int>(static_cast<std::size_t>(n), 1); }

TEST_CASE("1-dof landmarks with gaps, front rows of every size mod 4, several chunks: Schur step = dense solve",
          "[solver][problem]") {
  // 24, 22 (a last pair of columns), 23 (and an odd last column), 17 rows; 12 to 75 landmarks
  // (kDenseSchurRows = 32 per chunk).
  check_dense_schur({6, 6, 6, 6}, ones(40), 3);
  check_dense_schur({6, 6, 6, 4}, ones(75), 4);
  check_dense_schur({6, 6, 6, 4, 1}, ones(33), 5);
  check_dense_schur({5, 6, 6}, ones(12), 6);
}

TEST_CASE("1-dof landmarks around 2- and 3-dof ones: each ends the chunk before it, Schur step = dense solve",
          "[solver][problem]") {
  // A 3-dof landmark first, after 5 (a short chunk), after 32 + 9 (a full chunk and a partial
  // one), two in a row, and last; 2-dof ones in between.
  std::vector<int> dims = ones(80);
  for (int l : {0, 5, 46, 47, 79}) dims[static_cast<std::size_t>(l)] = 3;
  for (int l : {20, 60}) dims[static_cast<std::size_t>(l)] = 2;
  check_dense_schur({6, 6, 6, 6, 4}, dims, 7);
  check_dense_schur({6, 6, 5}, {1, 2, 1, 1, 3, 1, 2, 2, 1}, 8);
}

// Landmarks of lm_dim dofs over Euclidean blocks (no tail: one dense Cholesky of the reduced
// system), solved three accepted steps with the gradient pass, the kept factorization on or off;
// the state after the solve and its summary.
std::vector<double> solve_bent(const std::vector<int>& red_size, const std::vector<int>& lm_dim, Method method,
                               bool reuse_factor, SolverSummary* sum) {
  bench::Rng rng(11);
  auto randm = [&](int r, int c) { return random_matrix(rng, r, c); };
  std::vector<std::vector<double>> x;
  for (int t : red_size) x.emplace_back(static_cast<std::size_t>(t), 0.0);
  for (int e : lm_dim) x.emplace_back(static_cast<std::size_t>(e), 0.1);
  auto problem = std::make_unique<Problem>();
  const int nb = static_cast<int>(red_size.size());
  std::vector<BlockId> id(x.size());
  for (std::size_t k = 0; k < x.size(); ++k) {
    const int n = static_cast<int>(x[k].size());
    const bool lm = static_cast<int>(k) >= nb;
    REQUIRE((lm ? problem->add_landmark_block(x[k].data(), n, &id[k]) : problem->add_euclidean_block(x[k].data(), n, &id[k])) ==
            SolverStatus::kOk);
  }
  std::vector<std::unique_ptr<AffineResidual>> res;
  for (std::size_t l = 0; l < lm_dim.size(); ++l) {
    const int e = lm_dim[l];
    for (int k = 0; k < nb; ++k) {
      // Every block sees every landmark once, with 2 + e rows: each landmark's block is invertible.
      Eigen::VectorXd c(2 + e);
      for (int i = 0; i < 2 + e; ++i) c[i] = rng.normal();
      // Bent (0.3): a second step after the gradient pass is not a zero step.
      res.push_back(std::make_unique<AffineResidual>(randm(2 + e, red_size[static_cast<std::size_t>(k)]), randm(2 + e, e), c, 0.3));
      REQUIRE(problem->add_residual(res.back().get(), RobustLoss::trivial(),
                                    {id[static_cast<std::size_t>(k)], id[static_cast<std::size_t>(nb) + l]}) == SolverStatus::kOk);
    }
  }
  SolverOptions opt;
  opt.method = method;
  opt.initial_trust_region_radius = 1e3;  // pinned: the kept factor's damping is the fresh one's
  opt.max_trust_region_radius = 1e3;
  opt.max_successful_steps = 3;
  opt.function_tolerance = 0.0;
  opt.reuse_gauss_newton_matrix = true;
  opt.reuse_factorization = reuse_factor;
  REQUIRE(usable(problem->solve(opt, sum)));
  std::vector<double> out;
  for (const auto& v : x) out.insert(out.end(), v.begin(), v.end());
  return out;
}

TEST_CASE("Reusing the factorization: 1-, 2- and 3-dof landmarks, one dense Cholesky, LM and Gauss-Newton",
          "[solver][problem]") {
  const std::vector<int> red = {6, 5, 3};
  const std::vector<std::vector<int>> dims = {{1, 1, 1, 1, 1, 1, 1}, {1, 2, 1, 3, 3, 1, 2}, {3, 2}};
  for (const Method method : {Method::kLevenbergMarquardt, Method::kGaussNewton}) {
    for (const auto& lm : dims) {
      INFO("method " << static_cast<int>(method) << ", landmarks " << lm.size() << " (first " << lm[0] << " dofs)");
      SolverSummary fresh, kept;
      const std::vector<double> x_fresh = solve_bent(red, lm, method, false, &fresh);
      const std::vector<double> x_kept = solve_bent(red, lm, method, true, &kept);
      REQUIRE(fresh.successful_steps == 3);
      CHECK(kept.successful_steps == 3);
      CHECK(kept.gradient_passes == 1);
      CHECK(kept.factor_reuses == 1);
      // The steps are real. The problem is drawn through libm, whose last bits differ between
      // machines: no tighter bound on the decrease (on x86-64 0.62-0.64 of the start, on aarch64
      // one Gauss-Newton run 0.87).
      CHECK(fresh.final_cost < fresh.initial_cost);
      CHECK(kept.final_cost == fresh.final_cost);
      int differ = 0;
      for (std::size_t i = 0; i < x_fresh.size(); ++i) differ += x_kept[i] != x_fresh[i] ? 1 : 0;
      CHECK(differ == 0);
    }
  }
}

TEST_CASE("Eliminated blocks of 2 and 3 dofs and odd block sizes: Schur step = dense solve",
          "[solver][problem]") {
  bench::Rng rng(21);
  auto randm = [&](int r, int c) { return random_matrix(rng, r, c); };
  // Reduced blocks of 4, 5 and 1 dofs; 12 landmarks of 3 or 2 dofs, each seen 3 times.
  const int red_size[3] = {4, 5, 1};
  std::vector<std::vector<double>> x_red(3), x_lm(12);
  auto problem = std::make_unique<Problem>();
  BlockId red_id[3], lm_id[12];
  for (int k = 0; k < 3; ++k) {
    x_red[static_cast<std::size_t>(k)].assign(static_cast<std::size_t>(red_size[k]), 0.0);
    REQUIRE(problem->add_euclidean_block(x_red[static_cast<std::size_t>(k)].data(), red_size[k], &red_id[k]) == SolverStatus::kOk);
  }
  for (int l = 0; l < 12; ++l) {
    const int e = l % 2 == 0 ? 3 : 2;
    x_lm[static_cast<std::size_t>(l)].assign(static_cast<std::size_t>(e), 0.0);
    REQUIRE(problem->add_landmark_block(x_lm[static_cast<std::size_t>(l)].data(), e, &lm_id[l]) == SolverStatus::kOk);
  }
  std::vector<std::unique_ptr<AffineResidual>> res;
  const int dim = 10 + 6 * 3 + 6 * 2;
  auto col_of_red = [&](int k) { return k == 0 ? 0 : (k == 1 ? 4 : 9); };
  auto col_of_lm = [&](int l) { return 10 + (l / 2) * 5 + (l % 2 == 0 ? 0 : 3); };
  Eigen::MatrixXd Jd = Eigen::MatrixXd::Zero(12 * 3 * 4, dim);
  Eigen::VectorXd rd = Eigen::VectorXd::Zero(12 * 3 * 4);
  int row = 0;
  for (int l = 0; l < 12; ++l) {
    const int e = l % 2 == 0 ? 3 : 2;
    for (int k = 0; k < 3; ++k) {
      const Eigen::MatrixXd A = randm(4, red_size[k]), B = randm(4, e);
      Eigen::VectorXd c(4);
      for (int i = 0; i < 4; ++i) c[i] = rng.normal();
      res.push_back(std::make_unique<AffineResidual>(A, B, c));
      REQUIRE(problem->add_residual(res.back().get(), RobustLoss::trivial(), {red_id[k], lm_id[l]}) == SolverStatus::kOk);
      Jd.block(row, col_of_red(k), 4, red_size[k]) = A;
      Jd.block(row, col_of_lm(l), 4, e) = B;
      rd.segment(row, 4) = c;
      row += 4;
    }
  }
  const Eigen::VectorXd expected = -(Jd.transpose() * Jd).ldlt().solve(Jd.transpose() * rd);
  SolverSummary sum;
  REQUIRE(usable(problem->solve(one_step(Method::kGaussNewton), &sum)));
  double worst = 0.0;
  for (int k = 0; k < 3; ++k)
    for (int i = 0; i < red_size[k]; ++i)
      worst = std::max(worst, std::abs(x_red[static_cast<std::size_t>(k)][static_cast<std::size_t>(i)] - expected[col_of_red(k) + i]));
  for (int l = 0; l < 12; ++l)
    for (std::size_t i = 0; i < x_lm[static_cast<std::size_t>(l)].size(); ++i)
      worst = std::max(worst, std::abs(x_lm[static_cast<std::size_t>(l)][i] - expected[col_of_lm(l) + static_cast<int>(i)]));
  INFO("max |x - x_dense| " << worst << " |x_dense| " << expected.norm());
  CHECK(worst < 1e-10 * (1.0 + expected.lpNorm<Eigen::Infinity>()));
  // At the least-squares solution a second solve does not move (gradient ~ 0).
  SolverOptions opt;
  REQUIRE(usable(problem->solve(opt, &sum)));
  CHECK(sum.final_cost == Approx(sum.initial_cost).epsilon(1e-12));
}

}  // namespace
}  // namespace ums::solver

namespace ums::solver {
namespace {

TEST_CASE("A marginalization refused as too large leaves the problem solvable as before", "[solver][problem]") {
  // Four frames' poses and speed-biases are 60 dofs, above capacity::kMaxMarginalizedDim (48):
  // kFull. The next solve on the same problem must reach the optimum of the untouched problem.
  auto w = bench::make_vio_window(small_window(true, true));
  auto problem = std::make_unique<Problem>();
  REQUIRE(bench::add_to_problem(*w, *problem) == SolverStatus::kOk);
  std::vector<BlockId> ids;
  for (int f = 0; f < 4; ++f) {
    ids.push_back(block_id(*w, BlockRef{BlockKind::kPose, f}));
    ids.push_back(block_id(*w, BlockRef{BlockKind::kSpeedBias, f}));
  }
  // Their landmarks go with them (the solver requires it).
  for (int l = 0; l < static_cast<int>(w->inv_depth.size()); ++l)
    ids.push_back(block_id(*w, BlockRef{BlockKind::kInverseDepth, l}));
  MarginalPrior prior;
  REQUIRE(problem->marginalize(ids.data(), static_cast<int>(ids.size()), &prior) == SolverStatus::kFull);
  SolverOptions opt;
  opt.function_tolerance = 1e-12;
  SolverSummary sum;
  CHECK(usable(problem->solve(opt, &sum)));
  CHECK(sum.final_cost < 1e-12);
  double pos_err = 0.0;
  for (std::size_t i = 0; i < w->poses.size(); ++i)
    for (int k = 0; k < 3; ++k)
      pos_err = std::max(pos_err, std::abs(w->poses[i][static_cast<std::size_t>(k)] - w->poses_true[i][static_cast<std::size_t>(k)]));
  CHECK(pos_err < 1e-7);  // m
}

}  // namespace
}  // namespace ums::solver

namespace ums::solver {
namespace {

// Residual k of the window evaluated afresh at its current values (no Jacobians).
std::vector<double> fresh_residual(VioWindow& w, int k) {
  const bench::ResidualDesc& d = w.residuals[static_cast<std::size_t>(k)];
  const double* params[4] = {};
  for (int b = 0; b < d.num_blocks; ++b) params[b] = w.data(d.blocks[b]);
  std::vector<double> r(static_cast<std::size_t>(d.fn->num_residuals()));
  JacobianView none[4];
  REQUIRE(d.fn->evaluate(params, r.data(), none));
  return r;
}

}  // namespace

TEST_CASE("A solve keeps its residuals at the values it returns, bit for bit, until they move",
          "[solver][problem]") {
  auto w = bench::make_vio_window(small_window(false, true));
  auto problem = std::make_unique<Problem>();
  int checked = 0;
  bool saw_capped = false, saw_tolerance = false, saw_predicted = false;
  // Iteration caps that end on an accepted step or on a tolerance (the last candidate discarded),
  // with and without the predicted stop (no candidate formed).
  for (double radius : {1e4, 1e-3})
  for (double share : {0.0, 0.5}) {
    for (int iterations : {1, 2, 3, 5, 50}) {
      w->reset();
      REQUIRE(bench::add_to_problem(*w, *problem) == SolverStatus::kOk);
      SolverOptions opt;
      opt.max_iterations = iterations;
      opt.initial_trust_region_radius = radius;
      opt.predicted_stop_share = share;
      SolverSummary sum;
      REQUIRE(usable(problem->solve(opt, &sum)));
      saw_capped |= sum.termination == Termination::kMaxIterations;
      saw_tolerance |= sum.termination == Termination::kFunctionTolerance ||
                       sum.termination == Termination::kParameterTolerance;
      saw_predicted |= sum.termination == Termination::kPredictedFunctionTolerance;
      INFO("radius " << radius << " iterations " << iterations << ": " << sum.successful_steps << " of "
                     << sum.iterations << " steps accepted");
      REQUIRE(problem->solved_residuals_current());
      for (int k = 0; k < problem->num_residuals(); ++k) {
        const double* kept = problem->solved_residual(k);
        REQUIRE(kept != nullptr);
        const std::vector<double> r = fresh_residual(*w, k);
        for (std::size_t i = 0; i < r.size(); ++i) CHECK(kept[i] == r[i]);
        ++checked;
      }
    }
  }
  CHECK(checked > 1000);
  CHECK(saw_capped);
  CHECK(saw_tolerance);
  CHECK(saw_predicted);
  // A value moved after the solve: the kept residuals no longer describe the state.
  w->inv_depth[3] *= 1.01;
  CHECK_FALSE(problem->solved_residuals_current());
  w->inv_depth[3] /= 1.01;
  // Set-up again: nothing is known until the next solve.
  REQUIRE(bench::add_to_problem(*w, *problem) == SolverStatus::kOk);
  CHECK_FALSE(problem->solved_residuals_current());
}

// r = 10 (x^3 - 1): from x = 0.05, where the slope is small, the undamped step overshoots far.
class CubeResidual final : public ResidualFunction {
 public:
  int num_residuals() const override { return 1; }
  bool evaluate(const double* const* x, double* r, const JacobianView* jac) const override {
    r[0] = 10.0 * (x[0][0] * x[0][0] * x[0][0] - 1.0);
    if (jac[0].wanted()) jac[0].data[0] = 30.0 * x[0][0] * x[0][0];
    return true;
  }
};

TEST_CASE("After rejected steps the kept residual is the returned iterate's", "[solver][problem]") {
  auto problem = std::make_unique<Problem>();
  const CubeResidual f;
  for (int iterations : {1, 3, 6, 10, 14, 20}) {
    problem->clear();
    double x = 0.05;
    BlockId id = 0;
    REQUIRE(problem->add_euclidean_block(&x, 1, &id) == SolverStatus::kOk);
    REQUIRE(problem->add_residual(&f, RobustLoss::trivial(), {id}) == SolverStatus::kOk);
    SolverOptions opt;
    opt.max_iterations = iterations;
    opt.initial_trust_region_radius = 1e16;
    SolverSummary sum;
    REQUIRE(usable(problem->solve(opt, &sum)));
    INFO(iterations << " iterations: " << sum.successful_steps << " accepted, x = " << x);
    if (iterations == 1) CHECK(sum.successful_steps == 0);  // the first step overshoots
    REQUIRE(problem->solved_residuals_current());
    CHECK(problem->solved_residual(0)[0] == 10.0 * (x * x * x - 1.0));
  }
}

TEST_CASE("max_successful_steps ends the solve after that many accepted steps, rejected ones not counted, "
          "without linearizing at the last",
          "[solver][problem]") {
  auto problem = std::make_unique<Problem>();
  const CubeResidual f;
  // r = 10 (x^3 - 1) from x = 0.05 with an undamped start: the first steps overshoot and are
  // rejected, and the minimum x = 1 takes several accepted steps.
  double x = 0.0;  // the block's value: outlives each run
  auto run = [&](int max_iterations, int max_steps, SolverSummary* sum) {
    problem->clear();
    x = 0.05;
    BlockId id = 0;
    REQUIRE(problem->add_euclidean_block(&x, 1, &id) == SolverStatus::kOk);
    REQUIRE(problem->add_residual(&f, RobustLoss::trivial(), {id}) == SolverStatus::kOk);
    SolverOptions opt;
    opt.max_iterations = max_iterations;
    opt.max_successful_steps = max_steps;
    opt.initial_trust_region_radius = 1e16;
    opt.whole_pass_on_candidate = false;  // linearizations counted as Ceres makes them
    const SolverStatus st = problem->solve(opt, sum);
    REQUIRE(usable(st));
    if (sum->termination == Termination::kMaxSuccessfulSteps) CHECK(st == SolverStatus::kMaxIterations);
    return x;
  };
  SolverSummary full, one, two, capped;
  const double x_full = run(50, 0, &full);
  CHECK(std::abs(x_full - 1.0) < 1e-4);
  REQUIRE(full.successful_steps >= 3);
  const double x_one = run(50, 1, &one);
  INFO("one step: " << one.iterations << " attempts, x = " << x_one);
  CHECK(one.termination == Termination::kMaxSuccessfulSteps);
  CHECK(one.successful_steps == 1);
  CHECK(one.iterations > 1);        // the rejected attempts before it are not counted
  CHECK(one.linearizations == 1);   // only at the start
  CHECK(one.final_cost < one.initial_cost);
  REQUIRE(problem->solved_residuals_current());
  CHECK(problem->solved_residual(0)[0] == 10.0 * (x_one * x_one * x_one - 1.0));
  // The same attempts capped by max_iterations end at the same x, bit for bit: the budget
  // changes where the solve stops, not the step.
  const double x_capped = run(one.iterations, 0, &capped);
  CHECK(capped.termination == Termination::kMaxIterations);
  CHECK(x_capped == x_one);
  // Budget and cap on the same attempt: the budget is reported (the solve took its steps).
  SolverSummary both;
  CHECK(run(one.iterations, 1, &both) == x_one);
  CHECK(both.termination == Termination::kMaxSuccessfulSteps);
  const double x_two = run(50, 2, &two);
  CHECK(two.successful_steps == 2);
  CHECK(two.linearizations == 2);
  CHECK(two.final_cost < one.final_cost);
  CHECK(std::abs(x_two - 1.0) < std::abs(x_one - 1.0));
  // A budget the solve does not reach changes nothing.
  SolverSummary roomy;
  CHECK(run(50, full.successful_steps + 1, &roomy) == x_full);
  CHECK(roomy.termination == full.termination);
  SolverOptions bad;
  bad.max_successful_steps = -1;
  CHECK_FALSE(bad.validate());
}

TEST_CASE("A solve that fails keeps no residuals, one over constant blocks is not kept", "[solver][problem]") {
  auto problem = std::make_unique<Problem>();
  PointResidual m(1.0, 2.0);
  double x[2] = {0.0, 0.0}, y[2] = {0.0, 0.0};
  BlockId ix = 0, iy = 0;
  REQUIRE(problem->add_euclidean_block(x, 2, &ix) == SolverStatus::kOk);
  REQUIRE(problem->add_euclidean_block(y, 2, &iy) == SolverStatus::kOk);
  REQUIRE(problem->set_constant(iy, true) == SolverStatus::kOk);
  REQUIRE(problem->add_residual(&m, RobustLoss::trivial(), {ix}) == SolverStatus::kOk);
  REQUIRE(problem->add_residual(&m, RobustLoss::trivial(), {iy}) == SolverStatus::kOk);
  SolverSummary sum;
  REQUIRE(usable(problem->solve(SolverOptions{}, &sum)));
  REQUIRE(problem->solved_residuals_current());
  REQUIRE(problem->solved_residual(0) != nullptr);
  CHECK(std::abs(problem->solved_residual(0)[0]) < 1e-6);  // x reached (1, 2) (0.1 um)
  CHECK(problem->solved_residual(1) == nullptr);            // every block constant
  // A NaN start: the solve refuses, and nothing is kept.
  x[0] = std::numeric_limits<double>::quiet_NaN();
  CHECK(problem->solve(SolverOptions{}, &sum) == SolverStatus::kInvalidInput);
  CHECK_FALSE(problem->solved_residuals_current());
}

// Counts the passes that evaluate residuals (each linearization and each candidate's cost).
class PassCounter final : public EvaluationCallback {
 public:
  void prepare_for_evaluation() override { ++passes; }
  int passes = 0;
};

// One solve of the noisy 5-frame window from its start: summary, evaluation passes, final state.
struct CountedSolve {
  SolverSummary sum;
  int passes = 0;
  std::vector<double> x;
};
CountedSolve counted_solve(VioWindow& w, Problem& problem, const SolverOptions& opt) {
  CountedSolve out;
  w.reset();
  REQUIRE(bench::add_to_problem(w, problem) == SolverStatus::kOk);
  PassCounter counter;
  problem.set_evaluation_callback(&counter);
  REQUIRE(usable(problem.solve(opt, &out.sum)));
  problem.set_evaluation_callback(nullptr);
  REQUIRE(problem.solved_residuals_current());
  out.passes = counter.passes;
  out.x = snapshot(w);
  return out;
}

TEST_CASE("A step predicted below the function tolerance ends the solve without its cost pass",
          "[solver][problem]") {
  auto w = bench::make_vio_window(small_window(false, true));
  auto problem = std::make_unique<Problem>();
  SolverOptions opt;
  opt.function_tolerance = 1e-3;  // the estimator's
  opt.predicted_stop_share = 0.0;  // Ceres' tests
  const CountedSolve ceres = counted_solve(*w, *problem, opt);
  opt.predicted_stop_share = 0.5;  // the estimator's default
  const CountedSolve ours = counted_solve(*w, *problem, opt);
  INFO("cost " << ceres.sum.initial_cost << " -> " << ceres.sum.final_cost << ", " << ceres.sum.iterations
               << " iterations, " << ceres.passes << " / " << ours.passes << " passes");
  CHECK(ceres.sum.termination == Termination::kFunctionTolerance);
  CHECK(ours.sum.termination == Termination::kPredictedFunctionTolerance);
  CHECK(ours.passes == ceres.passes - 1);  // the discarded candidate's cost pass
  // Otherwise the same solve: the same iterate, bit for bit, cost and counts.
  CHECK(ours.x == ceres.x);
  CHECK(ours.sum.final_cost == ceres.sum.final_cost);
  CHECK(ours.sum.iterations == ceres.sum.iterations);
  CHECK(ours.sum.linearizations == ceres.sum.linearizations);
  // Gauss-Newton accepts every step: the share does not apply. Out of range: refused.
  opt.method = Method::kGaussNewton;
  const CountedSolve gn_ours = counted_solve(*w, *problem, opt);
  opt.predicted_stop_share = 0.0;
  const CountedSolve gn_ceres = counted_solve(*w, *problem, opt);
  CHECK(gn_ours.passes == gn_ceres.passes);
  CHECK(gn_ours.sum.termination == gn_ceres.sum.termination);
  CHECK(gn_ours.x == gn_ceres.x);
  opt.predicted_stop_share = 1.5;
  SolverSummary sum;
  CHECK(problem->solve(opt, &sum) == SolverStatus::kInvalidInput);
}


TEST_CASE("Reusing the Gauss-Newton matrix: the solve stops where the true gradient vanishes, the second "
          "linearization forming the gradient only",
          "[solver][problem]") {
  for (const bool lifts : {false, true}) {
    INFO("point lifts " << lifts);
    WindowConfig cfg = small_window(false, true);  // noisy: the optimum keeps residuals (J^T r = 0, r != 0)
    cfg.point_lifts = lifts;
    auto run = [&](bool reuse, std::vector<double>* state, SolverSummary* sum) {
      auto w = bench::make_vio_window(cfg);
      auto problem = std::make_unique<Problem>();
      REQUIRE(bench::add_to_problem(*w, *problem) == SolverStatus::kOk);
      SolverOptions opt;
      opt.function_tolerance = 1e-14;
      opt.parameter_tolerance = 1e-14;
      opt.gradient_tolerance = 1e-12;
      opt.reuse_gauss_newton_matrix = reuse;
      REQUIRE(usable(problem->solve(opt, sum)));
      state->clear();
      for (const auto& p : w->poses) state->insert(state->end(), p.begin(), p.end());
      for (const double d : w->inv_depth) state->push_back(d);
    };
    std::vector<double> x_full, x_reuse;
    SolverSummary full, reuse;
    run(false, &x_full, &full);
    run(true, &x_reuse, &reuse);
    INFO("Gauss-Newton: " << full.successful_steps << " steps, reused matrix: " << reuse.successful_steps);
    CHECK(full.gradient_passes == 0);
    REQUIRE(reuse.successful_steps >= 2);
    CHECK(reuse.gradient_passes == 1);  // at the first accepted step, whole linearizations after it

    CHECK(reuse.final_cost < 0.5 * reuse.initial_cost);
    // The same minimum (whole linearizations after the pass; the pass itself is checked by the
    // tests below).
    CHECK(std::abs(reuse.final_cost - full.final_cost) <= 1e-9 * full.final_cost);
    double dx = 0.0;
    for (std::size_t i = 0; i < x_full.size(); ++i) dx = std::max(dx, std::abs(x_full[i] - x_reuse[i]));
    CHECK(dx < 1e-6);
  }
}



namespace {

// Windows a step away from their start: one solve of two attempts without the gradient pass, as
// the estimator's window arrives warm at each frame. From a cold start the older matrix's step can
// fail (the window differs between the host's and the targets' random draws), and the refresh
// then hides the pass.
// The noisy small window with or without point lifts, frame 0's blocks hinted or not, warm.
struct WarmWindow {
  std::unique_ptr<VioWindow> w;
  std::unique_ptr<Problem> problem = std::make_unique<Problem>();
};

// Frame 0's pose and speed-bias and the landmarks it hosts (add_to_problem's block ids).
std::vector<BlockId> frame0_blocks(const VioWindow& w) {
  const int F = static_cast<int>(w.poses.size());
  std::vector<BlockId> marg = {0, F};
  for (std::size_t l = 0; l < w.host.size(); ++l)
    if (w.host[l] == 0) marg.push_back(2 * F + 1 + static_cast<int>(l));
  return marg;
}

WarmWindow warm_window(bool lifts, bool hint) {
  WindowConfig cfg = small_window(false, true);
  cfg.point_lifts = lifts;
  WarmWindow s;
  s.w = bench::make_vio_window(cfg);
  REQUIRE(bench::add_to_problem(*s.w, *s.problem) == SolverStatus::kOk);
  if (hint) {
    const std::vector<BlockId> marg = frame0_blocks(*s.w);
    REQUIRE(s.problem->set_marginalization_hint(marg.data(), static_cast<int>(marg.size())) == SolverStatus::kOk);
  }
  SolverOptions warm;
  warm.max_iterations = 2;
  SolverSummary sum;
  REQUIRE(usable(s.problem->solve(warm, &sum)));
  return s;
}

// r = 10 (x^3 - 1) from x0, undamped in effect (radius 1e16, whatever opt says): the solution.
double solve_cube(double x0, SolverOptions opt, SolverSummary* sum) {
  auto problem = std::make_unique<Problem>();
  const CubeResidual f;
  double x = x0;
  BlockId id = 0;
  REQUIRE(problem->add_euclidean_block(&x, 1, &id) == SolverStatus::kOk);
  REQUIRE(problem->add_residual(&f, RobustLoss::trivial(), {id}) == SolverStatus::kOk);
  opt.initial_trust_region_radius = 1e16;
  REQUIRE(usable(problem->solve(opt, sum)));
  return x;
}

}  // namespace

TEST_CASE("Reusing the Gauss-Newton matrix: the second step is the first matrix's step on the new gradient",
          "[solver][problem]") {
  // r = 10 (x^3 - 1), J = 30 x^2, from x0 = 0.95 with a radius so large that the damping is below
  // rounding: x1 = x0 - r0 / J0 (Gauss-Newton), then x2 = x1 - J1 r1 / J0^2 (gradient at x1, matrix
  // at x0). A gradient formed with J0 would give x1 - r1 / J0, Gauss-Newton x1 - r1 / J1.
  SolverOptions opt;
  opt.max_successful_steps = 2;
  opt.reuse_gauss_newton_matrix = true;
  SolverSummary sum;
  const double x = solve_cube(0.95, opt, &sum);
  REQUIRE(sum.successful_steps == 2);
  CHECK(sum.gradient_passes == 1);
  const double x0 = 0.95, r0 = 10.0 * (x0 * x0 * x0 - 1.0), J0 = 30.0 * x0 * x0;
  const double x1 = x0 - r0 / J0, r1 = 10.0 * (x1 * x1 * x1 - 1.0), J1 = 30.0 * x1 * x1;
  const double expected = x1 - J1 * r1 / (J0 * J0);
  CHECK(std::abs(x - expected) < 1e-12);
  CHECK(std::abs(x - (x1 - r1 / J0)) > 1e-4);  // the stale gradient's step lands elsewhere
  CHECK(std::abs(x - (x1 - r1 / J1)) > 1e-4);  // and so does the Gauss-Newton step
}

TEST_CASE("Reusing the factorization: the step after the gradient pass is the kept factor's, bit for bit",
          "[solver][problem]") {
  // With the trust region pinned (initial radius = max radius, every step accepted) the damping
  // of the step after the gradient pass is the one the first step's factor was formed with, so a
  // fresh Schur complement and factorization must give the very same step: the solves are the
  // same to the bit, one of them without its second factorization. Landmarks with and without
  // point lifts, frame 0 hinted or not (its landmarks' terms apart).
  for (const bool lifts : {false, true}) {
    for (const bool hint : {false, true}) {
      INFO("point lifts " << lifts << ", hinted " << hint);
      auto run = [&](bool reuse, SolverSummary* sum) {
        WarmWindow s = warm_window(lifts, hint);
        SolverOptions opt;
        opt.initial_trust_region_radius = 1e3;
        opt.max_trust_region_radius = 1e3;
        opt.max_successful_steps = 3;
        opt.reuse_gauss_newton_matrix = true;
        opt.reuse_factorization = reuse;
        REQUIRE(usable(s.problem->solve(opt, sum)));
        return snapshot(*s.w);
      };
      SolverSummary fresh, kept;
      const std::vector<double> x_fresh = run(false, &fresh), x_kept = run(true, &kept);
      REQUIRE(fresh.successful_steps == 3);
      CHECK(fresh.factor_reuses == 0);
      CHECK(kept.factor_reuses == 1);
      CHECK(kept.successful_steps == fresh.successful_steps);
      CHECK(kept.gradient_passes == 1);
      CHECK(kept.final_cost == fresh.final_cost);
      REQUIRE(x_kept.size() == x_fresh.size());
      int differ = 0;
      for (std::size_t i = 0; i < x_fresh.size(); ++i) differ += x_kept[i] != x_fresh[i] ? 1 : 0;
      CHECK(differ == 0);
    }
  }
}

TEST_CASE("Reusing the factorization: the earlier damping's step, the same minimum", "[solver][problem]") {
  // Default trust region: the radius grows at the first acceptance, so the kept factor's step is
  // damped more than a fresh one would be; it is another step, and the solve still ends at the
  // same minimum.
  auto run = [](bool reuse, SolverSummary* sum, std::vector<double>* x) {
    WarmWindow s = warm_window(false, false);
    SolverOptions opt;
    opt.function_tolerance = 1e-14;
    opt.parameter_tolerance = 1e-14;
    opt.gradient_tolerance = 1e-12;
    opt.reuse_gauss_newton_matrix = true;
    opt.reuse_factorization = reuse;
    REQUIRE(usable(s.problem->solve(opt, sum)));
    x->clear();
    for (const auto& p : s.w->poses) x->insert(x->end(), p.begin(), p.end());
    for (const double d : s.w->inv_depth) x->push_back(d);
  };
  SolverSummary fresh, kept, two_fresh, two_kept;
  std::vector<double> x_fresh, x_kept, x2_fresh, x2_kept;
  run(false, &fresh, &x_fresh);
  run(true, &kept, &x_kept);
  CHECK(kept.factor_reuses == 1);
  CHECK(std::abs(kept.final_cost - fresh.final_cost) <= 1e-9 * fresh.final_cost);
  double dx = 0.0;
  for (std::size_t i = 0; i < x_fresh.size(); ++i) dx = std::max(dx, std::abs(x_fresh[i] - x_kept[i]));
  CHECK(dx < 1e-6);
  // Two accepted steps only: the second differs (the earlier damping).
  auto run2 = [](bool reuse, SolverSummary* sum, std::vector<double>* x) {
    WarmWindow s = warm_window(false, false);
    SolverOptions opt;
    opt.max_successful_steps = 2;
    opt.reuse_gauss_newton_matrix = true;
    opt.reuse_factorization = reuse;
    REQUIRE(usable(s.problem->solve(opt, sum)));
    x->clear();
    for (const auto& p : s.w->poses) x->insert(x->end(), p.begin(), p.end());
    for (const double d : s.w->inv_depth) x->push_back(d);
  };
  run2(false, &two_fresh, &x2_fresh);
  run2(true, &two_kept, &x2_kept);
  REQUIRE(two_kept.successful_steps == 2);
  CHECK(two_kept.factor_reuses == 1);
  double d2 = 0.0;
  for (std::size_t i = 0; i < x2_fresh.size(); ++i) d2 = std::max(d2, std::abs(x2_fresh[i] - x2_kept[i]));
  CHECK(d2 > 0.0);
  // Both remove most of the cost above the minimum in their two steps (here 95 % fresh, 92 %
  // from the kept factor).
  const double excess0 = two_fresh.initial_cost - fresh.final_cost;
  CHECK(two_fresh.final_cost - fresh.final_cost < 0.2 * excess0);
  CHECK(two_kept.final_cost - fresh.final_cost < 0.2 * excess0);
}

TEST_CASE("Reusing the Gauss-Newton matrix: the gradient pass through point lifts equals the plain one",
          "[solver][problem]") {
  // Two accepted steps, the second from the gradient pass: with and without the landmarks' lifts
  // (problem_lift.cpp, finish_lift_gradient) the same step to rounding; the whole linearization's
  // second step differs from both (another matrix).
  auto run = [](bool lifts, bool reuse) {
    WarmWindow s = warm_window(lifts, false);
    const auto& w = s.w;
    const auto& problem = s.problem;
    SolverOptions opt;
    opt.max_successful_steps = 2;
    opt.reuse_gauss_newton_matrix = reuse;
    SolverSummary sum;
    REQUIRE(usable(problem->solve(opt, &sum)));
    REQUIRE(sum.successful_steps == 2);
    CHECK(sum.gradient_passes == (reuse ? 1 : 0));
    return snapshot(*w);
  };
  const std::vector<double> plain = run(false, true), lifted = run(true, true), whole = run(false, false);
  double d_lift = 0.0, d_whole = 0.0;
  for (std::size_t i = 0; i < plain.size(); ++i) {
    d_lift = std::max(d_lift, std::abs(plain[i] - lifted[i]));
    d_whole = std::max(d_whole, std::abs(plain[i] - whole[i]));
  }
  CHECK(d_lift < 1e-10);
  CHECK(d_whole > 1e-8);
}


TEST_CASE("Reusing the Gauss-Newton matrix: a step of the older matrix that fails is retried with the iterate's own",
          "[solver][problem]") {
  // r = 10 (x^3 - 1) from x0 = 0.8: the first step lands at 1.054, where the slope is 1.7 times
  // the first; the older matrix's step overshoots back to 0.90 and raises the cost. The iterate is
  // then linearized whole and the step retried at the same radius: one attempt and one
  // linearization more than Gauss-Newton, the same minimum. Shrinking the radius instead would
  // have taken an attempt per halving from 1e16.
  auto run = [](bool reuse, SolverSummary* sum) {
    SolverOptions opt;
    opt.reuse_gauss_newton_matrix = reuse;
    return solve_cube(0.8, opt, sum);
  };
  SolverSummary full, reuse;
  const double x_full = run(false, &full), x_reuse = run(true, &reuse);
  INFO("Gauss-Newton " << full.iterations << " attempts, reused matrix " << reuse.iterations);
  CHECK(reuse.gradient_passes == 1);
  CHECK(reuse.iterations == full.iterations + 1);
  CHECK(reuse.linearizations == full.linearizations + 1);
  CHECK(std::abs(x_reuse - 1.0) < 1e-6);
  CHECK(std::abs(x_reuse - x_full) < 1e-6);
}


TEST_CASE("Reusing the Gauss-Newton matrix: the gradient pass forms the whole linearization's gradient",
          "[solver][problem]") {
  // Two attempts: the first step is the same either way, then the linearization at its iterate is
  // whole or a gradient pass, and the second step is the solve's last (no linearization after it).
  // The last linearization's gradient (reduced rows and landmarks) must be the same bits: IMU-like
  // and reprojection residuals, the marginal prior, point lifts or not, the hinted landmarks' rows
  // summed apart or not.
  for (const bool lifts : {false, true})
  for (const bool hint : {false, true}) {
    INFO("point lifts " << lifts << ", hint " << hint);
    auto run = [&](bool reuse, std::vector<double>* g) {
      WarmWindow s = warm_window(lifts, hint);
      const auto& problem = s.problem;
      SolverOptions opt;
      opt.max_iterations = 2;
      opt.reuse_gauss_newton_matrix = reuse;
      SolverSummary sum;
      REQUIRE(usable(problem->solve(opt, &sum)));
      REQUIRE(sum.successful_steps >= 1);
      CHECK(sum.gradient_passes == (reuse ? 1 : 0));
      REQUIRE(sum.linearizations == 2);  // the pass's step was not refused (no whole pass after it)
      g->clear();
      for (int i = 0; i < problem->reduced_dim(); ++i) g->push_back(problem->reduced_gradient(i));
      for (int l = 0; l < problem->num_landmark_slots(); ++l)
        for (int k = 0; k < 3; ++k) g->push_back(problem->landmark_gradient(l, k));
    };
    std::vector<double> whole, pass;
    run(false, &whole);
    run(true, &pass);
    REQUIRE(whole.size() == pass.size());
    double g_max = 0.0;
    int differ = 0;
    for (std::size_t i = 0; i < whole.size(); ++i) {
      g_max = std::max(g_max, std::abs(whole[i]));
      differ += whole[i] != pass[i];
    }
    CHECK(g_max > 1e-3);  // not at a minimum: the comparison sees every term
    CHECK(differ == 0);
  }
}

}  // namespace ums::solver

namespace ums::solver {
namespace {

// r = 10 (x^3 - 1), counting its evaluations (with or without the Jacobian). With fail_jacobian
// = k, its k-th evaluation that wants the Jacobian fails (the others succeed).
class CountedCube final : public ResidualFunction {
 public:
  int num_residuals() const override { return 1; }
  bool evaluate(const double* const* x, double* r, const JacobianView* jac) const override {
    ++evaluations;
    if (jac[0].wanted() && ++jacobian_evaluations == fail_jacobian) return false;
    r[0] = 10.0 * (x[0][0] * x[0][0] * x[0][0] - 1.0);
    if (jac[0].wanted()) jac[0].data[0] = 30.0 * x[0][0] * x[0][0];
    return true;
  }
  mutable int evaluations = 0;
  mutable int jacobian_evaluations = 0;
  int fail_jacobian = 0;
};

struct CubeRun {
  double x = 0.0;
  int evaluations = 0;
  int jacobian_evaluations = 0;
  SolverSummary sum;
};

// The counted cube from x0 with opt; gradient (if given): the solver's gradient at the end.
CubeRun solve_counted_cube_with(double x0, const SolverOptions& opt, int fail_jacobian, double* gradient = nullptr) {
  auto problem = std::make_unique<Problem>();
  CountedCube f;
  f.fail_jacobian = fail_jacobian;
  CubeRun run;
  run.x = x0;
  BlockId id = 0;
  REQUIRE(problem->add_euclidean_block(&run.x, 1, &id) == SolverStatus::kOk);
  REQUIRE(problem->add_residual(&f, RobustLoss::trivial(), {id}) == SolverStatus::kOk);
  REQUIRE(usable(problem->solve(opt, &run.sum)));
  run.evaluations = f.evaluations;
  run.jacobian_evaluations = f.jacobian_evaluations;
  if (gradient != nullptr) *gradient = problem->reduced_gradient(0);
  return run;
}

CubeRun solve_counted_cube(double x0, double radius, bool on_candidate, int fail_jacobian = 0) {
  SolverOptions opt;
  opt.reuse_gauss_newton_matrix = true;
  opt.gradient_pass_on_candidate = on_candidate;
  opt.initial_trust_region_radius = radius;
  return solve_counted_cube_with(x0, opt, fail_jacobian);
}

}  // namespace

TEST_CASE("The candidate's gradient pass: the same solve with one sweep fewer, refused candidates included",
          "[solver][problem]") {
  // From 0.95 every step is taken: the first candidate's cost comes from the gradient pass that
  // accepting it runs anyway. From 0.3 the undamped first steps overshoot (x near 3.9) and are
  // refused until the radius is small enough: each refused candidate's pass is undone, and the
  // solve goes on from the iterate's own gradient.
  for (const double x0 : {0.95, 0.3}) {
    INFO("x0 " << x0);
    const double radius = x0 > 0.5 ? 1e16 : 1e4;
    const CubeRun plain = solve_counted_cube(x0, radius, false), fused = solve_counted_cube(x0, radius, true);
    CHECK(fused.x == plain.x);  // the same bits
    CHECK(std::abs(fused.x - 1.0) < 1e-6);
    CHECK(fused.sum.iterations == plain.sum.iterations);
    CHECK(fused.sum.successful_steps == plain.sum.successful_steps);
    CHECK(fused.sum.linearizations == plain.sum.linearizations);
    CHECK(fused.sum.gradient_passes == 1);
    CHECK(fused.sum.final_cost == plain.sum.final_cost);
    if (x0 > 0.5) {
      CHECK(fused.evaluations == plain.evaluations - 1);
    } else {
      CHECK(plain.sum.iterations > plain.sum.successful_steps + 2);  // refused candidates
      CHECK(fused.evaluations == plain.evaluations - 1);              // the accepted one's sweep
    }
  }
}

TEST_CASE("The candidate's gradient pass fails where its cost pass would not: the plain cost pass decides",
          "[solver][problem]") {
  // The second Jacobian evaluation is the first candidate's gradient pass: it fails and its terms
  // are put back. From 0.95 the cost pass accepts the candidate and the acceptance runs the
  // gradient pass; from 0.3 it refuses it, and the next step needs the iterate's own gradient.
  for (const double x0 : {0.95, 0.3}) {
    INFO("x0 " << x0);
    const double radius = x0 > 0.5 ? 1e16 : 1e4;
    const CubeRun plain = solve_counted_cube(x0, radius, false), failed = solve_counted_cube(x0, radius, true, 2);
    CHECK(failed.x == plain.x);  // the same bits
    CHECK(failed.sum.iterations == plain.sum.iterations);
    CHECK(failed.sum.successful_steps == plain.sum.successful_steps);
    CHECK(failed.sum.linearizations == plain.sum.linearizations);
    CHECK(failed.sum.final_cost == plain.sum.final_cost);
    CHECK(std::abs(failed.x - 1.0) < 1e-6);
    CHECK(failed.jacobian_evaluations >= 2);  // the failure was injected
    // Accepted: the failed pass, then the plain run's passes. Refused: one pass more for the
    // failure, one fewer where a later first candidate's gradient pass is accepted.
    CHECK(failed.evaluations == plain.evaluations + (x0 > 0.5 ? 1 : 0));
  }
}

namespace {

// r = 10 (x^3 - 1) from x0 with plain Levenberg-Marquardt (no gradient pass), the candidate's
// whole pass on or off; gradient: the solver's gradient at the end.
CubeRun solve_cube_whole_pass(double x0, double radius, bool whole, double function_tolerance, double* gradient,
                              int fail_jacobian = 0) {
  SolverOptions opt;
  opt.whole_pass_on_candidate = whole;
  opt.initial_trust_region_radius = radius;
  opt.function_tolerance = function_tolerance;
  return solve_counted_cube_with(x0, opt, fail_jacobian, gradient);
}

}  // namespace

TEST_CASE("The candidate's whole pass: the same solve with fewer sweeps, refused and discarded candidates included",
          "[solver][problem]") {
  // From 0.95 every step is taken: each candidate worth it is linearized whole instead of being
  // costed first and linearized after. From 0.3 the first steps overshoot and are refused: the
  // first refused candidate's pass is undone by linearizing the iterate again, and the next
  // candidates are costed first until one is taken. From 2/3 the undamped step lands where
  // |r| is the same (r = -7.03 -> +7.02): its model predicts the whole cost away, so the pass
  // runs, and the function tolerance (0.1) then discards it and ends the solve.
  struct Case {
    double x0, radius, ftol;
  };
  for (const Case c : {Case{0.95, 1e16, 1e-6}, Case{0.3, 1e4, 1e-6}, Case{0.667, 1e16, 0.1}}) {
    INFO("x0 " << c.x0);
    double g_plain = 0.0, g_whole = 0.0;
    const CubeRun plain = solve_cube_whole_pass(c.x0, c.radius, false, c.ftol, &g_plain);
    const CubeRun whole = solve_cube_whole_pass(c.x0, c.radius, true, c.ftol, &g_whole);
    CHECK(whole.x == plain.x);  // the same bits
    CHECK(g_whole == g_plain);  // the iterate's system is back after a discarded candidate
    CHECK(whole.sum.iterations == plain.sum.iterations);
    CHECK(whole.sum.successful_steps == plain.sum.successful_steps);
    CHECK(whole.sum.final_cost == plain.sum.final_cost);
    CHECK(whole.sum.termination == plain.sum.termination);
    if (c.x0 > 0.9) {
      CHECK(std::abs(whole.x - 1.0) < 1e-6);
      CHECK(whole.jacobian_evaluations == plain.jacobian_evaluations);
      CHECK(whole.evaluations < plain.evaluations);  // cost passes saved
      CHECK(whole.sum.residual_passes == whole.evaluations);
    } else if (c.x0 < 0.5) {
      CHECK(std::abs(whole.x - 1.0) < 1e-6);
      CHECK(plain.sum.iterations > plain.sum.successful_steps + 2);  // refused candidates
      CHECK(whole.jacobian_evaluations == plain.jacobian_evaluations + 2);  // the first refused one, and its undoing
    } else {
      REQUIRE(plain.sum.termination == Termination::kFunctionTolerance);
      REQUIRE(plain.sum.successful_steps == 0);
      CHECK(plain.evaluations == 2);  // the start, the candidate's cost
      CHECK(whole.evaluations == 3);  // the start, the candidate's whole pass, the iterate's again
      CHECK(whole.sum.linearizations == plain.sum.linearizations + 2);
    }
  }
}

TEST_CASE("The candidate's whole pass fails: the cost pass decides, the iterate's system comes back",
          "[solver][problem]") {
  // The second Jacobian evaluation is the first candidate's whole pass: it fails, the plain cost
  // pass accepts the candidate and the acceptance linearizes it. The solve is the one without the
  // whole pass, bit for bit.
  double g_plain = 0.0, g_failed = 0.0;
  const CubeRun plain = solve_cube_whole_pass(0.95, 1e16, false, 1e-6, &g_plain);
  const CubeRun failed = solve_cube_whole_pass(0.95, 1e16, true, 1e-6, &g_failed, 2);
  CHECK(failed.x == plain.x);
  CHECK(g_failed == g_plain);
  CHECK(failed.sum.iterations == plain.sum.iterations);
  CHECK(failed.sum.successful_steps == plain.sum.successful_steps);
  CHECK(failed.sum.final_cost == plain.sum.final_cost);
  CHECK(failed.sum.termination == plain.sum.termination);
  CHECK(failed.jacobian_evaluations > plain.jacobian_evaluations);  // the failed pass ran
}

namespace {

// How many of two equally long outcomes' values differ in any bit (all of them if the lengths differ).
int values_differing(const std::vector<double>& a, const std::vector<double>& b) {
  if (a.size() != b.size()) return static_cast<int>(std::max(a.size(), b.size()));
  int differ = 0;
  for (std::size_t i = 0; i < a.size(); ++i) differ += a[i] != b[i];
  return differ;
}

// A solved window's state, gradient and (frame 0 marginalized) marginal prior, in that order.
void window_outcome(WarmWindow& s, std::vector<double>* out) {
  out->clear();
  for (const auto& p : s.w->poses) out->insert(out->end(), p.begin(), p.end());
  for (const double d : s.w->inv_depth) out->push_back(d);
  for (int i = 0; i < s.problem->reduced_dim(); ++i) out->push_back(s.problem->reduced_gradient(i));
  for (int l = 0; l < s.problem->num_landmark_slots(); ++l)
    for (int k = 0; k < 3; ++k) out->push_back(s.problem->landmark_gradient(l, k));
  const std::vector<BlockId> marg = frame0_blocks(*s.w);
  auto prior = std::make_unique<MarginalPrior>();
  REQUIRE(s.problem->marginalize(marg.data(), static_cast<int>(marg.size()), prior.get()) == SolverStatus::kOk);
  const auto H = prior->information();
  out->insert(out->end(), H.data(), H.data() + H.size());
  out->insert(out->end(), prior->r0().data(), prior->r0().data() + prior->r0().size());
}

// How a window solve's first candidate ends (the candidate's gradient pass runs, or must not).
enum class FirstCandidate { kAccepted, kRefused, kLastStep, kConverged };

// The noisy window (lifts or not, frame 0 hinted) solved so that its first candidate ends as
// asked, with or without the candidate's gradient pass; then frame 0 marginalized. out: the
// state, the gradient, the marginal prior.
SolverSummary window_first_candidate(bool lifts, FirstCandidate how, bool on_candidate, std::vector<double>* out) {
  WarmWindow s = warm_window(lifts, true);
  SolverOptions opt;
  opt.max_iterations = 3;
  opt.reuse_gauss_newton_matrix = true;
  opt.gradient_pass_on_candidate = on_candidate;
  if (how == FirstCandidate::kRefused) opt.min_relative_decrease = 2.0;  // twice what its model predicts
  if (how == FirstCandidate::kLastStep) opt.max_successful_steps = 1;
  if (how == FirstCandidate::kConverged) {
    SolverOptions converge;
    converge.function_tolerance = 1e-12;
    SolverSummary first;
    REQUIRE(usable(s.problem->solve(converge, &first)));
    opt.function_tolerance = 1e-3;  // at the minimum: the first candidate's change is below it
  }
  SolverSummary sum;
  REQUIRE(usable(s.problem->solve(opt, &sum)));
  window_outcome(s, out);
  return sum;
}

}  // namespace

TEST_CASE("The candidate's gradient pass on a window: the same bits however the first candidate ends",
          "[solver][problem]") {
  // Accepted: the pass is the gradient pass, one sweep fewer. Refused (an acceptance test no step
  // passes), or ending the solve on the function tolerance: the iterate's gradient and the hinted
  // landmarks' separated terms (which the marginalization reuses) must come back as they were.
  // The last permitted step: no gradient pass follows, so the candidate takes a cost pass.
  // Compared bit for bit: the state, the gradient and the marginal prior.
  for (const bool lifts : {false, true})
  for (const FirstCandidate how : {FirstCandidate::kAccepted, FirstCandidate::kRefused, FirstCandidate::kLastStep,
                                   FirstCandidate::kConverged}) {
    INFO("point lifts " << lifts << ", ending " << static_cast<int>(how));
    std::vector<double> plain, fused;
    const SolverSummary sp = window_first_candidate(lifts, how, false, &plain);
    const SolverSummary sf = window_first_candidate(lifts, how, true, &fused);
    switch (how) {
      case FirstCandidate::kAccepted:
        REQUIRE(sp.gradient_passes == 1);
        CHECK(sf.residual_passes == sp.residual_passes - 1);
        break;
      case FirstCandidate::kRefused:
        REQUIRE(sp.successful_steps == 0);
        CHECK(sf.residual_passes == sp.residual_passes);
        break;
      case FirstCandidate::kLastStep:
        REQUIRE(sp.termination == Termination::kMaxSuccessfulSteps);
        CHECK(sf.residual_passes == sp.residual_passes);
        break;
      case FirstCandidate::kConverged:
        REQUIRE(sp.termination == Termination::kFunctionTolerance);
        REQUIRE(sp.successful_steps == 0);
        CHECK(sf.residual_passes == sp.residual_passes);
        break;
    }
    CHECK(sf.iterations == sp.iterations);
    CHECK(sf.successful_steps == sp.successful_steps);
    CHECK(sf.linearizations == sp.linearizations);
    CHECK(sf.final_cost == sp.final_cost);
    CHECK(values_differing(fused, plain) == 0);
  }
}

namespace {

// The noisy window (lifts or not, frame 0 hinted) solved by plain Levenberg-Marquardt with the
// candidate's whole pass on or off, every candidate taken or (an acceptance test no step passes)
// every one refused; then frame 0 marginalized. out: as window_first_candidate's.
SolverSummary window_whole_pass(bool lifts, bool refuse, bool whole, std::vector<double>* out) {
  WarmWindow s = warm_window(lifts, true);
  SolverOptions opt;
  opt.max_iterations = 4;
  opt.whole_pass_on_candidate = whole;
  if (refuse) opt.min_relative_decrease = 2.0;  // twice what its model predicts
  SolverSummary sum;
  REQUIRE(usable(s.problem->solve(opt, &sum)));
  window_outcome(s, out);
  return sum;
}

}  // namespace

TEST_CASE("The candidate's whole pass on a window: the same bits, taken or refused", "[solver][problem]") {
  // Taken: a cost pass fewer per candidate worth the pass. Refused: the iterate's system, with
  // the hinted landmarks' separated terms that the marginalization reuses, comes back from a
  // second linearization of the iterate. Compared bit for bit: the state, the gradient and the
  // marginal prior.
  for (const bool lifts : {false, true})
  for (const bool refuse : {false, true}) {
    INFO("point lifts " << lifts << ", refused " << refuse);
    std::vector<double> plain, whole;
    const SolverSummary sp = window_whole_pass(lifts, refuse, false, &plain);
    const SolverSummary sw = window_whole_pass(lifts, refuse, true, &whole);
    if (refuse) {
      REQUIRE(sp.successful_steps == 0);
      CHECK(sw.linearizations == sp.linearizations + 2);  // the first candidate's pass, its undoing
    } else {
      REQUIRE(sp.successful_steps >= 2);
      CHECK(sw.linearizations == sp.linearizations);
      CHECK(sw.residual_passes < sp.residual_passes);
    }
    CHECK(sw.iterations == sp.iterations);
    CHECK(sw.successful_steps == sp.successful_steps);
    CHECK(sw.final_cost == sp.final_cost);
    CHECK(values_differing(whole, plain) == 0);
  }
}

}  // namespace ums::solver
