// umsvins_bench_solver: the hand-written Schur-complement LM of solver/ against Ceres 2.1 on one
// VIO-shaped window (vio_window.hpp: 11 keyframes of pose + speed-bias, an extrinsic, ~300
// inverse-depth landmarks with 3..11 observations, stereo and mono reprojection with Huber,
// 15-dim IMU-like residuals, a dense prior), same start, same residual code, same manifold, same
// LM settings and tolerances, one thread. Ceres runs DENSE_SCHUR and SPARSE_SCHUR with an explicit
// elimination ordering (landmarks first); the faster one is the peer. Problem construction is
// timed apart from the solve; medians over --runs solves. The LAST line printed is JSON.
//
//   umsvins_bench_solver [--runs N] [--landmarks N] [--frames N] [--seed N] [--max-iterations N]
//                        [--fixed-extrinsic 1] [--ours-only 1] [--point-lifts 0] [--reuse-matrix 1]
//                        [--whole-pass 0]
// --point-lifts 0: ours linearizes every reprojection with its own host and inverse-depth
// Jacobians instead of through the landmark's point (solver/residual.hpp, PointLift).

#include <ceres/ceres.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <ctime>
#include <memory>
#include <string>
#include <vector>

#include "profiling/solver_bench/vio_window.hpp"
#include "solver/problem.hpp"

namespace {

using ums::bench::BlockKind;
using ums::bench::BlockRef;
using ums::bench::VioWindow;
namespace us = ums::solver;

double now_s() {
  return std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch()).count();
}

// CPU time of this thread: on the shared 2-core build machine (load ~10) wall time measures the
// scheduler as much as the solver; both solvers run single-threaded, so thread CPU time is the
// work each one does. Wall medians are printed too.
double cpu_s() {
  timespec ts{};
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
  return static_cast<double>(ts.tv_sec) + 1e-9 * static_cast<double>(ts.tv_nsec);
}

double median(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  const std::size_t n = v.size();
  return n % 2 == 1 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]);
}

int ambient_of(BlockKind k) {
  return k == BlockKind::kSpeedBias ? 9 : (k == BlockKind::kInverseDepth ? 1 : 7);
}

// The same retraction as ours (manifold.hpp). Cost functions return [d_r_d_tangent | 0] (the
// seventh column zero), so the plus-Jacobian [I6; 0] turns them into exactly our Jacobians.
class PoseManifold final : public ceres::Manifold {
 public:
  int AmbientSize() const override { return 7; }
  int TangentSize() const override { return 6; }
  bool Plus(const double* x, const double* delta, double* x_plus) const override {
    us::manifold_plus(us::ManifoldType::kPose, 7, x, delta, x_plus);
    return true;
  }
  bool PlusJacobian(const double* /*x*/, double* jacobian) const override {
    std::fill(jacobian, jacobian + 42, 0.0);
    for (int i = 0; i < 6; ++i) jacobian[i * 6 + i] = 1.0;
    return true;
  }
  bool Minus(const double* y, const double* x, double* y_minus_x) const override {
    us::manifold_minus(us::ManifoldType::kPose, 7, y, x, y_minus_x);
    return true;
  }
  bool MinusJacobian(const double* /*x*/, double* jacobian) const override {
    std::fill(jacobian, jacobian + 42, 0.0);
    for (int i = 0; i < 6; ++i) jacobian[i * 7 + i] = 1.0;
    return true;
  }
};

// Our ResidualFunction as an analytic Ceres CostFunction (no copies: Jacobians are written with
// the ambient row stride, the pose's unused seventh column is zeroed).
class ResidualAdapter final : public ceres::CostFunction {
 public:
  ResidualAdapter(const us::ResidualFunction* fn, const int* ambient, int n) : fn_(fn), n_(n) {
    set_num_residuals(fn->num_residuals());
    for (int k = 0; k < n; ++k) {
      ambient_[k] = ambient[k];
      mutable_parameter_block_sizes()->push_back(ambient[k]);
    }
  }
  bool Evaluate(double const* const* parameters, double* residuals,
                double** jacobians) const override {
    us::JacobianView views[us::capacity::kMaxBlocksPerResidual];
    for (int k = 0; k < n_; ++k)
      views[k] = {jacobians != nullptr ? jacobians[k] : nullptr, ambient_[k]};
    if (!fn_->evaluate(parameters, residuals, views)) return false;
    const int rows = fn_->num_residuals();
    for (int k = 0; k < n_; ++k)
      if (views[k].wanted() && ambient_[k] == 7)
        for (int i = 0; i < rows; ++i) views[k].data[i * 7 + 6] = 0.0;
    return true;
  }

 private:
  const us::ResidualFunction* fn_;
  int n_;
  int ambient_[us::capacity::kMaxBlocksPerResidual] = {};
};

class PriorAdapter final : public ceres::CostFunction {
 public:
  explicit PriorAdapter(const us::MarginalPrior* prior) : prior_(prior) {
    set_num_residuals(prior->dim());
    for (int i = 0; i < prior->num_blocks(); ++i)
      mutable_parameter_block_sizes()->push_back(prior->block(i).ambient_size);
  }
  bool Evaluate(double const* const* parameters, double* residuals,
                double** jacobians) const override {
    us::JacobianView views[us::capacity::kMaxReducedBlocks];
    for (int i = 0; i < prior_->num_blocks(); ++i)
      views[i] = {jacobians != nullptr ? jacobians[i] : nullptr, prior_->block(i).ambient_size};
    if (!prior_->evaluate(parameters, residuals, jacobians != nullptr ? views : nullptr))
      return false;
    for (int i = 0; i < prior_->num_blocks(); ++i)
      if (views[i].wanted() && views[i].row_stride == 7)
        for (int r = 0; r < prior_->dim(); ++r) views[i].data[r * 7 + 6] = 0.0;
    return true;
  }

 private:
  const us::MarginalPrior* prior_;
};

struct Sample {
  double build_ms = 0.0;
  double solve_ms = 0.0;       // thread CPU time
  double solve_wall_ms = 0.0;  // wall time
};

std::vector<double> state_of(VioWindow& w) {
  std::vector<double> s;
  for (auto& p : w.poses) s.insert(s.end(), p.begin(), p.end());
  for (auto& p : w.speed_bias) s.insert(s.end(), p.begin(), p.end());
  s.insert(s.end(), w.extrinsic.begin(), w.extrinsic.end());
  s.insert(s.end(), w.inv_depth.begin(), w.inv_depth.end());
  return s;
}

// Ceres on the window: cost-function adapters are made once (like our residual objects); each
// solve builds a fresh ceres::Problem (as VINS-Fusion does every frame), timed apart.
class CeresRunner {
 public:
  CeresRunner(VioWindow& w, const us::SolverOptions& o, bool fixed_extrinsic)
      : w_(w), o_(o), fixed_extrinsic_(fixed_extrinsic), huber_(w.config.huber_delta) {
    for (const auto& r : w.residuals) {
      int amb[4];
      for (int k = 0; k < r.num_blocks; ++k) amb[k] = ambient_of(r.blocks[k].kind);
      costs_.push_back(std::make_unique<ResidualAdapter>(r.fn, amb, r.num_blocks));
    }
    if (w.prior) prior_cost_ = std::make_unique<PriorAdapter>(w.prior.get());
  }

  Sample solve_once(ceres::LinearSolverType type, bool verbose, ceres::Solver::Summary* summary) {
    VioWindow& w = w_;
    w.reset();
    Sample s;
    const double t0 = cpu_s();
    ceres::Problem::Options po;
    po.cost_function_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;
    po.loss_function_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;
    po.manifold_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;
    ceres::Problem problem(po);
    const int F = static_cast<int>(w.poses.size());
    for (int i = 0; i < F; ++i) problem.AddParameterBlock(w.poses[i].data(), 7, &pose_manifold_);
    for (int i = 0; i < F; ++i) problem.AddParameterBlock(w.speed_bias[i].data(), 9);
    problem.AddParameterBlock(w.extrinsic.data(), 7, &pose_manifold_);
    if (fixed_extrinsic_) problem.SetParameterBlockConstant(w.extrinsic.data());
    for (auto& rho : w.inv_depth) problem.AddParameterBlock(&rho, 1);
    std::vector<double*> blocks;
    for (std::size_t k = 0; k < w.residuals.size(); ++k) {
      const auto& r = w.residuals[k];
      blocks.clear();
      for (int b = 0; b < r.num_blocks; ++b) blocks.push_back(w.data(r.blocks[b]));
      problem.AddResidualBlock(costs_[k].get(),
                               r.loss.type == us::LossType::kHuber ? &huber_ : nullptr, blocks);
    }
    if (prior_cost_) {
      blocks.clear();
      for (const BlockRef& b : w.prior_blocks) blocks.push_back(w.data(b));
      problem.AddResidualBlock(prior_cost_.get(), nullptr, blocks);
    }
    auto* ordering = new ceres::ParameterBlockOrdering;
    for (auto& rho : w.inv_depth) ordering->AddElementToGroup(&rho, 0);
    for (int i = 0; i < F; ++i) {
      ordering->AddElementToGroup(w.poses[i].data(), 1);
      ordering->AddElementToGroup(w.speed_bias[i].data(), 1);
    }
    ordering->AddElementToGroup(w.extrinsic.data(), 1);
    ceres::Solver::Options so;
    so.linear_solver_type = type;
    so.linear_solver_ordering.reset(ordering);
    so.trust_region_strategy_type = ceres::LEVENBERG_MARQUARDT;
    so.num_threads = 1;  // also required: the residuals share a PairProductCache without locks
    so.max_num_iterations = o_.max_iterations;
    so.max_solver_time_in_seconds = 1e6;
    so.function_tolerance = o_.function_tolerance;
    so.gradient_tolerance = o_.gradient_tolerance;
    so.parameter_tolerance = o_.parameter_tolerance;
    so.initial_trust_region_radius = o_.initial_trust_region_radius;
    so.max_trust_region_radius = o_.max_trust_region_radius;
    so.min_trust_region_radius = o_.min_trust_region_radius;
    so.min_lm_diagonal = o_.min_lm_diagonal;
    so.max_lm_diagonal = o_.max_lm_diagonal;
    so.min_relative_decrease = o_.min_relative_decrease;
    so.max_num_consecutive_invalid_steps = o_.max_consecutive_invalid_steps;
    so.jacobi_scaling = o_.jacobi_scaling;
    so.use_nonmonotonic_steps = false;
    so.logging_type = verbose ? ceres::PER_MINIMIZER_ITERATION : ceres::SILENT;
    so.minimizer_progress_to_stdout = verbose;
    const double t1 = cpu_s();
    const double w1 = now_s();
    ceres::Solve(so, &problem, summary);
    s.solve_ms = 1e3 * (cpu_s() - t1);
    s.solve_wall_ms = 1e3 * (now_s() - w1);
    s.build_ms = 1e3 * (t1 - t0);
    return s;
  }

 private:
  VioWindow& w_;
  us::SolverOptions o_;
  bool fixed_extrinsic_;
  PoseManifold pose_manifold_;
  ceres::HuberLoss huber_;
  std::vector<std::unique_ptr<ceres::CostFunction>> costs_;
  std::unique_ptr<ceres::CostFunction> prior_cost_;
};

double median_of(const std::vector<Sample>& v, double Sample::*field) {
  std::vector<double> x;
  for (const Sample& s : v) x.push_back(s.*field);
  return median(x);
}

int arg_int(int argc, char** argv, const char* name, int def) {
  for (int i = 1; i + 1 < argc; ++i)
    if (std::strcmp(argv[i], name) == 0) return std::atoi(argv[i + 1]);
  return def;
}

}  // namespace

int main(int argc, char** argv) {
  ums::bench::WindowConfig cfg;
  cfg.frames = arg_int(argc, argv, "--frames", 11);
  cfg.landmarks = arg_int(argc, argv, "--landmarks", 300);
  cfg.seed = static_cast<std::uint64_t>(arg_int(argc, argv, "--seed", 42));
  cfg.point_lifts = arg_int(argc, argv, "--point-lifts", 1) != 0;
  const int runs = std::max(1, arg_int(argc, argv, "--runs", 9));
  us::SolverOptions opt;  // Ceres' defaults
  opt.max_iterations = arg_int(argc, argv, "--max-iterations", 20);
  // --reuse-matrix 1: ours with the estimator's gradient pass (not Ceres' algorithm step for step).
  opt.reuse_gauss_newton_matrix = arg_int(argc, argv, "--reuse-matrix", 0) != 0;
  // --whole-pass 0: ours costs every candidate in a pass of its own before linearizing it, as
  // Ceres does (the same steps either way; SolverOptions::whole_pass_on_candidate).
  opt.whole_pass_on_candidate = arg_int(argc, argv, "--whole-pass", 1) != 0;

  auto w = ums::bench::make_vio_window(cfg);
  int n_reproj = 0, n_stereo_host = 0, n_imu = 0;
  for (const auto& r : w->residuals) {
    if (r.fn->num_residuals() == 15) ++n_imu;
    else if (r.num_blocks == 1) ++n_stereo_host;
    else ++n_reproj;
  }
  std::printf("window: %d keyframes, %d landmarks, %d reprojection (mono+stereo, other frames), %d "
              "stereo-in-host, %d IMU-like, prior dim %d, seed %llu\n",
              cfg.frames, cfg.landmarks, n_reproj, n_stereo_host, n_imu,
              w->prior ? w->prior->dim() : 0, static_cast<unsigned long long>(cfg.seed));

  // Runs are interleaved (ours, Ceres dense, Ceres sparse, ours, ...) so that the load of the
  // shared machine falls on all three alike.
  auto problem = std::make_unique<us::Problem>();
  const bool fixed_extrinsic = arg_int(argc, argv, "--fixed-extrinsic", 0) != 0;
  CeresRunner ceres_runner(*w, opt, fixed_extrinsic);
  const bool verbose = std::getenv("UMS_BENCH_VERBOSE") != nullptr;
  const bool ours_only = arg_int(argc, argv, "--ours-only", 0) != 0;
  const ceres::LinearSolverType types[2] = {ceres::DENSE_SCHUR, ceres::SPARSE_SCHUR};
  const char* names[2] = {"DENSE_SCHUR", "SPARSE_SCHUR"};
  std::vector<Sample> ours;
  std::vector<Sample> peer[2];
  us::SolverSummary sum;
  us::SolverStatus st = us::SolverStatus::kOk;
  ceres::Solver::Summary csum[2];
  std::vector<double> ours_state, ceres_state[2];
  for (int run = 0; run < runs; ++run) {
    w->reset();
    Sample s;
    const double t0 = cpu_s();
    if (ums::bench::add_to_problem(*w, *problem) != us::SolverStatus::kOk ||
        (fixed_extrinsic && problem->set_constant(2 * cfg.frames, true) != us::SolverStatus::kOk)) {
      std::fprintf(stderr, "problem set-up failed\n");
      return 1;
    }
    const double t1 = cpu_s();
    const double w1 = now_s();
    st = problem->solve(opt, &sum);
    s.solve_ms = 1e3 * (cpu_s() - t1);
    s.solve_wall_ms = 1e3 * (now_s() - w1);
    s.build_ms = 1e3 * (t1 - t0);
    ours.push_back(s);
    if (run == 0) ours_state = state_of(*w);
    if (ours_only) continue;
    for (int k = 0; k < 2; ++k) {
      peer[k].push_back(ceres_runner.solve_once(types[k], verbose && run == 0, &csum[k]));
      if (run == 0) ceres_state[k] = state_of(*w);
    }
  }
  std::vector<double> ours_solve;
  for (const Sample& s : ours) ours_solve.push_back(s.solve_ms);
  const double ours_ms = median_of(ours, &Sample::solve_ms);
  std::printf("ours: status %s, reduced dim %d, iterations %d (%d successful), cost %.12g -> "
              "%.12g, build %.3f ms, solve median %.3f ms cpu (min %.3f), %.3f ms wall\n",
              us::to_string(st), problem->reduced_dim(), sum.iterations, sum.successful_steps,
              sum.initial_cost, sum.final_cost, median_of(ours, &Sample::build_ms), ours_ms,
              *std::min_element(ours_solve.begin(), ours_solve.end()),
              median_of(ours, &Sample::solve_wall_ms));
  if (ours_only) return 0;

  int best = 0;
  for (int k = 0; k < 2; ++k) {
    const ceres::Solver::Summary& cs = csum[k];
    double dx = 0.0;
    for (std::size_t i = 0; i < ours_state.size(); ++i)
      dx = std::max(dx, std::abs(ceres_state[k][i] - ours_state[i]));
    std::printf("ceres %s: iterations %d, final cost %.12g, build %.3f ms, solve median %.3f ms "
                "cpu, %.3f ms wall, max |x_ceres - x_ours| %.3g; schur structure %s, "
                "preprocessor %.2f ms, jacobian eval %.2f ms, linear solver %.2f ms (Ceres' wall "
                "clocks), successful steps %d, termination %s\n",
                names[k], static_cast<int>(cs.iterations.size()) - 1, cs.final_cost,
                median_of(peer[k], &Sample::build_ms), median_of(peer[k], &Sample::solve_ms),
                median_of(peer[k], &Sample::solve_wall_ms), dx, cs.schur_structure_used.c_str(),
                1e3 * cs.preprocessor_time_in_seconds, 1e3 * cs.jacobian_evaluation_time_in_seconds,
                1e3 * cs.linear_solver_time_in_seconds, cs.num_successful_steps,
                ceres::TerminationTypeToString(cs.termination_type));
    if (median_of(peer[k], &Sample::solve_ms) < median_of(peer[best], &Sample::solve_ms)) best = k;
  }
  const double ceres_ms = median_of(peer[best], &Sample::solve_ms);
  const double rel = std::abs(sum.final_cost - csum[best].final_cost) / csum[best].final_cost;
  std::printf("{\"ours_ms\": %.4f, \"ceres_ms\": %.4f, \"ceres_linear_solver\": \"%s\", "
              "\"speedup\": %.3f, \"cost_rel_diff\": %.3g, \"iterations_ours\": %d, "
              "\"iterations_ceres\": %d}\n",
              ours_ms, ceres_ms, names[best], ceres_ms / ours_ms, rel, sum.iterations,
              static_cast<int>(csum[best].iterations.size()) - 1);
  return 0;
}
