// The Levenberg-Marquardt loop (docs/solver.md, "Step" and "Levenberg-Marquardt"): Ceres 2.1's
// trust region step for step, the damped Schur-complement step (landmark elimination, the
// factorization of the reduced system, back-substitution) and the acceptance of candidates.
#include "solver/problem.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>

#include "solver/dense_cholesky.hpp"
#include "solver/dense_schur.hpp"
#include "solver/double_pair.hpp"
#include "solver/finite.hpp"

namespace ums::solver {
namespace {

double seconds_since(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

using Small = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, 0, 3, 3>;
using SmallVector = Eigen::Matrix<double, Eigen::Dynamic, 1, 0, 3, 1>;

}  // namespace

// One solve(): the trust region (Ceres' LevenbergMarquardtStrategy and TrustRegionMinimizer
// state), the costs and the summary being filled.
struct Problem::LmState {
  explicit LmState(const SolverOptions& o) : options(o) {}
  // Ends the solve with its status, termination and reported cost; returns false ("stop").
  bool end(SolverStatus s, Termination t, double cost) {
    status = s;
    summary.termination = t;
    summary.final_cost = cost;
    return false;
  }
  // An invalid or rejected step: radius /= factor, factor *= 2.
  void shrink() {
    radius /= decrease_factor;
    decrease_factor *= 2.0;
  }

  const SolverOptions& options;
  const std::chrono::steady_clock::time_point t0 = std::chrono::steady_clock::now();
  SolverSummary summary;
  SolverStatus status = SolverStatus::kOk;
  bool lm = false;
  double fixed = 0.0;   // cost of the residuals and priors over constant blocks only
  double x_cost = 0.0;  // variable cost at the current iterate
  double grad_norm = 0.0;
  double radius = 0.0;
  double decrease_factor = 2.0;
  double x_norm = -1.0;  // as Ceres: unknown until the first accepted step
  bool step_successful = true;
  bool stale_matrix = false;  // H is not the iterate's own (a gradient pass formed b only)
  bool refused_last = false;  // the last candidate was refused (whole_pass_on_candidate waits)
  int invalid_steps = 0;
  int iteration = 0;
};

SolverStatus Problem::solve(const SolverOptions& options, SolverSummary* summary) {
  LmState s(options);
  kept_valid_ = false;
  factor_valid_ = false;  // S_ may hold a marginalization's matrix, or another layout's factor
  residual_passes_ = 0;
  bool running = start_solve(s);
  while (running) running = iterate(s);
  if (usable(s.status)) snapshot_solution();
  s.summary.residual_passes = residual_passes_;
  s.summary.solve_time_s = seconds_since(s.t0);
  if (summary != nullptr) *summary = s.summary;
  return s.status;
}

// Options, structure, finite values, the fixed cost and iteration 0's linearization and scaling.
bool Problem::start_solve(LmState& s) {
  const SolverOptions& o = s.options;
  if (!o.validate()) return s.end(SolverStatus::kInvalidInput, Termination::kFailure, 0.0);
  const SolverStatus st = prepare();
  if (st != SolverStatus::kOk) return s.end(st, Termination::kFailure, 0.0);
  min_diag_ = o.min_lm_diagonal;
  max_diag_ = o.max_lm_diagonal;
  s.lm = o.method == Method::kLevenbergMarquardt;

  for (int i = 0; i < num_blocks_; ++i)
    if (!all_finite(blocks_[i].x, blocks_[i].ambient))
      return s.end(SolverStatus::kInvalidInput, Termination::kFailure, 0.0);
  s.fixed = fixed_cost();
  if (!std::isfinite(s.fixed)) return s.end(SolverStatus::kInvalidInput, Termination::kFailure, 0.0);

  // Iteration 0.
  kept_write_ = kept_cur_;
  const bool linearized = linearize(true, &s.x_cost);
  kept_write_ = -1;
  if (!linearized) return s.end(SolverStatus::kInvalidInput, Termination::kFailure, 0.0);
  ++s.summary.linearizations;
  s.summary.initial_cost = s.x_cost + s.fixed;
  set_jacobi_scaling(o.jacobi_scaling);
  s.grad_norm = gradient_max_norm();
  s.radius = o.initial_trust_region_radius;
  return true;
}

// Ceres' Jacobi scaling s_i = 1 / (1 + sqrt(H_ii)) from the first linearization (or 1).
void Problem::set_jacobi_scaling(bool jacobi) {
  for (int i = 0; i < n_red_; ++i)
    scale_red_[i] = jacobi ? 1.0 / (1.0 + std::sqrt(H_.m()(i, i))) : 1.0;
  for (int l = 0; l < num_lm_; ++l)
    for (int p = 0; p < lm_dim_[l]; ++p)
      scale_l_[l][p] = jacobi ? 1.0 / (1.0 + std::sqrt(Hll_[l][p * lm_dim_[l] + p])) : 1.0;
}

// One iteration: termination tests, step, candidate cost, tolerances, acceptance. false: ended.
bool Problem::iterate(LmState& s) {
  if (!can_continue(s)) return false;
  ++s.iteration;
  s.summary.iterations = s.iteration;
  s.step_successful = false;
  double mcc = 0.0;
  const double lm_scale = s.lm ? 1.0 / s.radius : 0.0;
  // Right after a gradient pass the matrix is still the one the last step factored; its damping
  // is kept when it is not below the trust region's (the region grew at the acceptance).
  const bool kept_factor =
      s.stale_matrix && s.options.reuse_factorization && factor_valid_ && factor_lm_scale_ >= lm_scale;
  const bool valid = (kept_factor ? compute_step_kept_factor(&mcc) : compute_step(lm_scale, &mcc)) && (mcc > 0.0 || !s.lm);
  if (!valid) return s.stale_matrix ? refresh_matrix(s) : reject_invalid_step(s);
  if (kept_factor) ++s.summary.factor_reuses;
  s.invalid_steps = 0;
  if (predicted_converged(s, mcc)) return false;

  const double step_norm = apply_candidate();
  double cand_cost = 0.0;
  kept_write_ = 1 - kept_cur_;  // the candidate's residuals: current if it is accepted
  if (!evaluate_candidate(s, mcc, step_norm, &cand_cost)) cand_cost = std::numeric_limits<double>::max();
  kept_write_ = -1;
  if (candidate_converged(s, step_norm, cand_cost)) {
    // Ended: the iterate's system still goes back, for the marginalization and the gradient readers.
    if (!drop_candidate_linearization(s)) s.end(SolverStatus::kNumericalFailure, Termination::kFailure, s.x_cost + s.fixed);
    return false;
  }
  const double relative_decrease = (s.x_cost - cand_cost) / mcc;
  const bool accept = s.lm ? relative_decrease > s.options.min_relative_decrease
                           : cand_cost < std::numeric_limits<double>::max();
  if (accept) return accept_step(s, cand_cost, relative_decrease);
  restore_values();
  if (!drop_candidate_linearization(s))
    return s.end(SolverStatus::kNumericalFailure, Termination::kFailure, s.x_cost + s.fixed);
  s.refused_last = true;
  if (s.stale_matrix) return refresh_matrix(s);
  s.shrink();
  return true;
}

// A step of the gradient pass's older matrix failed: that is the matrix's fault, not the trust
// region's. The iterate is linearized whole and the step tried again with the same radius (a
// solve from far away would otherwise shrink the region and crawl back over many steps).
bool Problem::refresh_matrix(LmState& s) {
  s.stale_matrix = false;
  if (!linearize(true, &s.x_cost))
    return s.end(SolverStatus::kNumericalFailure, Termination::kFailure, s.x_cost + s.fixed);
  ++s.summary.linearizations;
  s.grad_norm = gradient_max_norm();
  return true;
}

// Termination tests in Ceres' order (FinalizeIterationAndCheckIfMinimizerCanContinue).
bool Problem::can_continue(LmState& s) {
  const SolverOptions& o = s.options;
  const double cost = s.x_cost + s.fixed;
  if (seconds_since(s.t0) >= o.max_time_s)
    return s.end(SolverStatus::kTimeBudget, Termination::kTimeBudget, cost);
  if (s.iteration >= o.max_iterations)
    return s.end(SolverStatus::kMaxIterations, Termination::kMaxIterations, cost);
  if (s.step_successful && s.grad_norm <= o.gradient_tolerance)
    return s.end(SolverStatus::kConverged, Termination::kGradientTolerance, cost);
  if (s.lm && s.radius <= o.min_trust_region_radius)
    return s.end(SolverStatus::kConverged, Termination::kMinTrustRegionRadius, cost);
  return true;
}

// Failed factorization, non-finite step or no model decrease. false: ended.
bool Problem::reject_invalid_step(LmState& s) {
  if (++s.invalid_steps >= s.options.max_consecutive_invalid_steps || !s.lm)
    return s.end(SolverStatus::kNumericalFailure, Termination::kFailure, s.x_cost + s.fixed);
  s.shrink();
  return true;
}

// Candidate x [+] dx written in place (old values backed up); returns |x_new - x| (ambient).
double Problem::apply_candidate() {
  double ambient_tmp[capacity::kMaxBlockAmbientSize];
  double delta_tmp[capacity::kMaxBlockTangentSize];
  double step_sq = 0.0;
  for (int i = 0; i < num_blocks_; ++i) {
    const Block& b = blocks_[i];
    if (b.constant) continue;
    const double* d = b.eliminate ? dl_[b.index] : nullptr;
    if (!b.eliminate) {
      for (int j = 0; j < b.tangent; ++j) delta_tmp[j] = dx_[b.index + j];
      d = delta_tmp;
    }
    manifold_plus(b.manifold, b.ambient, b.x, d, ambient_tmp);
    for (int j = 0; j < b.ambient; ++j) {
      backup_[i][j] = b.x[j];
      const double dj = ambient_tmp[j] - b.x[j];
      step_sq += dj * dj;
      b.x[j] = ambient_tmp[j];
    }
  }
  return std::sqrt(step_sq);
}

void Problem::restore_values() {
  for (int i = 0; i < num_blocks_; ++i) {
    const Block& b = blocks_[i];
    if (b.constant) continue;
    for (int j = 0; j < b.ambient; ++j) b.x[j] = backup_[i][j];
  }
}

// A step whose model change is a small share of the function tolerance ends the solve before
// its candidate is formed and evaluated: Ceres would evaluate it and discard it under that
// tolerance, unless the model under-predicted the change by 1 / predicted_stop_share or more.
bool Problem::predicted_converged(LmState& s, double model_change) {
  const SolverOptions& o = s.options;
  if (!s.lm || !(o.predicted_stop_share > 0.0) ||
      !(model_change <= o.predicted_stop_share * o.function_tolerance * s.x_cost))
    return false;
  s.summary.iterations = s.iteration - 1;  // as candidate_converged: the attempt is not listed
  s.end(SolverStatus::kConverged, Termination::kPredictedFunctionTolerance, s.x_cost + s.fixed);
  return true;
}

// Ceres' parameter tolerance: |x_new - x| <= tol (|x| + tol).
bool Problem::step_small(const LmState& s, double step_norm) {
  const double tol = s.options.parameter_tolerance;
  return step_norm <= tol * (s.x_norm + tol);
}

// Parameter tolerance |x_new - x| <= tol (|x| + tol), then function tolerance |cost change| <=
// tol * cost: either discards the candidate and ends the solve (true).
bool Problem::candidate_converged(LmState& s, double step_norm, double cand_cost) {
  const SolverOptions& o = s.options;
  Termination t;
  if (step_small(s, step_norm))
    t = Termination::kParameterTolerance;
  else if (std::abs(s.x_cost - cand_cost) <= o.function_tolerance * s.x_cost)
    t = Termination::kFunctionTolerance;
  else
    return false;
  restore_values();
  s.summary.iterations = s.iteration - 1;  // as Ceres: the attempt that ends the solve is not listed
  s.end(SolverStatus::kConverged, t, s.x_cost + s.fixed);
  return true;
}

// The candidate becomes the iterate: linearized there (unless it is the last permitted step),
// radius /= max(1/3, 1 - (2 rho - 1)^3). false: ended.
bool Problem::accept_step(LmState& s, double cand_cost, double relative_decrease) {
  const SolverOptions& o = s.options;
  s.x_cost = cand_cost;
  kept_cur_ = 1 - kept_cur_;  // the candidate pass kept its residuals
  // The last permitted step: the loop's next tests end the solve before any of them reads
  // the Jacobians, so linearizing here would only be thrown away (the time test still comes
  // first, as in the loop). A window solve capped at 3 iterations saves 1 of its 7 passes.
  const bool last_step = step_budget_spent(s);
  if (last_permitted_step(s)) {
    ++s.summary.successful_steps;
    if (seconds_since(s.t0) >= o.max_time_s)
      return s.end(SolverStatus::kTimeBudget, Termination::kTimeBudget, s.x_cost + s.fixed);
    // The budget first: a solve that took its N steps ended as designed, even on its last attempt.
    return s.end(SolverStatus::kMaxIterations, last_step ? Termination::kMaxSuccessfulSteps : Termination::kMaxIterations,
                 s.x_cost + s.fixed);
  }
  s.x_norm = variable_x_norm();
  const bool gradient_only = gradient_only_at_acceptance(s);
  // The candidate's own pass was this gradient pass (evaluate_candidate): its cost is x_cost.
  const bool linearized = candidate_linearized_ ||
                          (gradient_only ? linearize_gradient(&s.x_cost) : linearize(true, &s.x_cost));
  candidate_linearized_ = false;
  iterate_system_spoiled_ = false;
  s.refused_last = false;
  if (!linearized) {
    restore_values();
    kept_cur_ = 1 - kept_cur_;
    return s.end(SolverStatus::kNumericalFailure, Termination::kFailure, s.x_cost + s.fixed);
  }
  ++s.summary.linearizations;
  if (gradient_only) ++s.summary.gradient_passes;
  s.stale_matrix = gradient_only;
  s.grad_norm = gradient_max_norm();
  s.step_successful = true;
  ++s.summary.successful_steps;
  const double q = 2.0 * relative_decrease - 1.0;
  s.radius = std::min(o.max_trust_region_radius,
                      s.radius / std::max(1.0 / 3.0, 1.0 - q * q * q));
  s.decrease_factor = 2.0;
  return true;
}

bool Problem::step_budget_spent(const LmState& s) const {
  const SolverOptions& o = s.options;
  return o.max_successful_steps > 0 && s.summary.successful_steps + 1 >= o.max_successful_steps;
}

bool Problem::last_permitted_step(const LmState& s) const {
  return s.iteration >= s.options.max_iterations || step_budget_spent(s);
}

// After the first accepted step only: later ones are far from a warm start, where a matrix that
// old would slow the convergence.
bool Problem::gradient_only_at_acceptance(const LmState& s) const {
  return s.options.reuse_gauss_newton_matrix && s.summary.successful_steps == 0;
}

// accept_step() would form the gradient alone at the candidate, and not end the solve first.
bool Problem::gradient_pass_follows(const LmState& s) const {
  return gradient_only_at_acceptance(s) && !last_permitted_step(s);
}

bool Problem::candidate_takes_gradient_pass(const LmState& s) const {
  return s.options.gradient_pass_on_candidate && gradient_pass_follows(s);
}

// Accepting would linearize the candidate whole, and it is likely to be accepted: the last
// candidate was not refused (after a refusal the region is still being found), its model change
// is well above the function tolerance's share of the cost (near the minimum a candidate is most
// often discarded under that tolerance), and the parameter tolerance does not discard it. Not on
// a stale matrix: that iterate's system is not what a whole linearization gives back.
bool Problem::candidate_takes_whole_pass(const LmState& s, double model_change, double step_norm) const {
  // Under this share the candidate would be discarded only if its cost changed by less than a
  // third of what its model predicts: near the minimum, where the model is good, that is rare,
  // and a wasted whole pass costs several cost passes.
  constexpr double kModelShare = 3.0;
  const SolverOptions& o = s.options;
  return o.whole_pass_on_candidate && !s.stale_matrix && !s.refused_last && !gradient_only_at_acceptance(s) &&
         !last_permitted_step(s) && model_change > kModelShare * o.function_tolerance * s.x_cost &&
         !step_small(s, step_norm);
}

// The candidate's residuals with their Jacobians when accepting it would run that pass anyway
// (the gradient pass, or a whole linearization that looks worth the gamble): the cost pass is
// that pass, and nothing changes but the work (the same residuals and the same sums in the same
// order). A pass that fails leaves the decision to the plain cost pass, as before, whose
// acceptance then runs the pass itself.
bool Problem::evaluate_candidate(const LmState& s, double model_change, double step_norm, double* cost) {
  candidate_linearized_ = false;
  iterate_system_spoiled_ = false;
  if (candidate_takes_gradient_pass(s)) {
    keep_gradient_terms();
    candidate_linearized_ = linearize_gradient(cost);
    if (candidate_linearized_) return true;
    restore_gradient_terms();
  } else if (candidate_takes_whole_pass(s, model_change, step_norm)) {
    iterate_system_spoiled_ = true;  // from here H, b, the landmarks' terms are the candidate's
    candidate_linearized_ = linearize(true, cost);
    if (candidate_linearized_) return true;
  }
  return linearize(false, cost);
}

// The candidate is not taken (its values already restored): the iterate's terms again. After a
// whole pass, by linearizing the iterate again: the same values, residuals and order give the
// same bits. false: that linearization failed (it did not, the first time).
bool Problem::drop_candidate_linearization(LmState& s) {
  const bool spoiled = iterate_system_spoiled_, gradient = candidate_linearized_ && !spoiled;
  if (spoiled && candidate_linearized_) ++s.summary.linearizations;  // the candidate's, not taken
  candidate_linearized_ = false;
  iterate_system_spoiled_ = false;
  if (gradient) restore_gradient_terms();
  if (!spoiled) return true;
  double cost = 0.0;
  if (!linearize(true, &cost)) return false;
  ++s.summary.linearizations;
  return true;
}

// What a gradient pass writes: b, g_l, bsep and, when hinted, the separated linearization point.
void Problem::keep_gradient_terms() {
  kept_b_ = b_;
  if (hinted_) kept_bsep_ = bsep_.head(n_front_);
  for (int l = 0; l < num_lm_; ++l)
    for (int i = 0; i < 3; ++i) kept_gl_[l][i] = gl_[l][i];
  kept_sep_valid_ = sep_valid_;
  if (!hinted_) return;
  for (int i = 0; i < num_blocks_; ++i) std::copy(lin_x_[i], lin_x_[i] + blocks_[i].ambient, kept_lin_x_[i]);
}

void Problem::restore_gradient_terms() {
  b_ = kept_b_;
  if (hinted_) bsep_.head(n_front_) = kept_bsep_;
  for (int l = 0; l < num_lm_; ++l)
    for (int i = 0; i < 3; ++i) gl_[l][i] = kept_gl_[l][i];
  sep_valid_ = kept_sep_valid_;
  if (!hinted_) return;
  for (int i = 0; i < num_blocks_; ++i) std::copy(kept_lin_x_[i], kept_lin_x_[i] + blocks_[i].ambient, lin_x_[i]);
}

// The values the solve returns, so that solved_residuals_current() can tell whether they moved.
void Problem::snapshot_solution() {
  for (int i = 0; i < num_blocks_; ++i) {
    const Block& b = blocks_[i];
    if (!b.constant) std::copy(b.x, b.x + b.ambient, solved_x_[i]);
  }
  kept_valid_ = true;
}

bool Problem::solved_residuals_current() const {
  if (!kept_valid_ || !prepared_) return false;
  for (int i = 0; i < num_blocks_; ++i) {
    const Block& b = blocks_[i];
    if (!b.constant && !std::equal(b.x, b.x + b.ambient, solved_x_[i])) return false;
  }
  return true;
}

bool Problem::compute_step(double lm_scale, double* model_cost_change) {
  const bool damp = lm_scale > 0.0;
  factor_valid_ = false;
  form_reduced_system(lm_scale, damp);
  eliminate_all(lm_scale, S_.m(), rhs_, damp);
  if (n_red_ > 0 && !factor_reduced_system()) return false;
  factor_valid_ = true;
  factor_lm_scale_ = lm_scale;
  return finish_step(lm_scale, model_cost_change);
}

// The step of the damping the kept factor was formed with (factor_lm_scale_), for the gradient
// b_, g_l a gradient pass formed since: H, the couplings and H_ll are the factor's, so only the
// reduced right-hand side is formed again, in eliminate_all's order. The same doubles as
// compute_step(factor_lm_scale_) would give, without the Schur complement and its factorization.
bool Problem::compute_step_kept_factor(double* model_cost_change) {
  if (!factor_valid_) return false;
  const double lm_scale = factor_lm_scale_;
  const bool damp = lm_scale > 0.0;
  rhs_ = b_;
  for (int l = 0; l < num_lm_; ++l) {
    if (lm_dim_[l] != 1) {
      if (invert_landmark_block(l, lm_scale, damp)) subtract_landmark_block_gradient(l, rhs_);
      continue;
    }
    const double w = invert_landmark1(l, lm_scale, damp);
    if (w != 0.0) subtract_landmark1_gradient(l, w * gl_[l][0], rhs_);
  }
  return finish_step(lm_scale, model_cost_change);
}

// dx from the factor in S_ and rhs_, the landmarks' back-substitution and the model decrease
// -(g^T dx + 0.5 dx^T H dx), computed from the damped normal equations (H + D) dx = -g as
// -0.5 g^T dx + 0.5 dx^T D dx.
bool Problem::finish_step(double lm_scale, double* model_cost_change) {
  const bool damp = lm_scale > 0.0;
  if (n_red_ > 0 && !solve_factored()) return false;
  double gdx = b_.dot(dx_);
  double dDd = 0.0;
  if (damp)
    for (int i = 0; i < n_red_; ++i) dDd += dx_[i] * dx_[i] * d_red_[i];
  for (int l = 0; l < num_lm_; ++l) {
    if (std::isinf(dl_[l][0])) {  // skipped by the elimination (invert_landmark1): no step
      for (int p = 0; p < lm_dim_[l]; ++p) dl_[l][p] = 0.0;
      continue;
    }
    back_substitute(l);
    add_landmark_model_terms(l, lm_scale, damp, &gdx, &dDd);
    if (!std::isfinite(dl_[l][0])) return false;
  }
  *model_cost_change = -0.5 * gdx + 0.5 * dDd;
  return std::isfinite(*model_cost_change);
}

// S = H + D (upper triangle; D the LM diagonal of the reduced blocks, kept in d_red_), rhs = b.
void Problem::form_reduced_system(double lm_scale, bool damp) {
  // Only the upper triangle is ever read (Schur updates and the Upper LLT).
  S_.m().triangularView<Eigen::Upper>() = H_.m();
  rhs_ = b_;
  if (!damp) return;
  MatrixMap S = S_.m();
  const ConstMatrixMap H = static_cast<const DenseMatrix&>(H_).m();
  for (int i = 0; i < n_red_; ++i) {
    const double s2 = scale_red_[i] * scale_red_[i];
    d_red_[i] = lm_scale * std::clamp(H(i, i) * s2, min_diag_, max_diag_) / s2;
    S(i, i) += d_red_[i];
  }
}

// 1-dof landmark l's damped h inverted: dl_[l][0] keeps w = 1/h for back-substitution, or inf
// ("skipped") when h is not positive, then 0 is returned.
double Problem::invert_landmark1(int l, double lm_scale, bool damp) {
  double h = Hll_[l][0];
  if (damp) h += lm_scale * std::clamp(h * scale_l_[l][0] * scale_l_[l][0], min_diag_, max_diag_) /
                 (scale_l_[l][0] * scale_l_[l][0]);
  if (!(h > 0.0)) {
    dl_[l][0] = std::numeric_limits<double>::infinity();
    return 0.0;
  }
  dl_[l][0] = 1.0 / h;
  return dl_[l][0];
}

// Every landmark's Schur complement into S, rhs: S -= V W V^T, rhs -= V W g, landmark after
// landmark in slot order, so every element receives the terms in that order whatever the grouping:
// the same doubles as one landmark at a time. 1-dof landmarks (nearly all) go in chunks of dense
// rows (dense_schur.hpp): S is read and written once per chunk. A landmark of 2 or 3 dofs ends the
// chunk before it and is eliminated on its own. marginalized: only the landmarks marked in marg_.
void Problem::eliminate_all(double lm_scale, MatrixMap S, DenseVector& rhs, bool damp, bool marginalized) {
  int n = 0;
  for (int l = 0; l < num_lm_; ++l) {
    if (marginalized && !marg_[lm_block_[l]]) continue;
    if (lm_dim_[l] != 1) {
      flush_dense_rows(n, S);
      n = 0;
      eliminate_landmark_block(l, lm_scale, S, rhs, damp);
      continue;
    }
    const double w = invert_landmark1(l, lm_scale, damp);
    if (w == 0.0) continue;  // skipped: touches nothing
    gather_dense_row(l, w, n++, rhs);
    if (n == kDenseSchurRows) {
      flush_dense_rows(n, S);
      n = 0;
    }
  }
  flush_dense_rows(n, S);
}

// S -= the products of dense rows 0..n-1 (dense_schur.hpp).
void Problem::flush_dense_rows(int n, MatrixMap S) {
  if (n == 0) return;
  const double* v[kDenseSchurRows];
  const double* u2[kDenseSchurRows];
  for (int m = 0; m < n; ++m) {
    v[m] = dense_v_[m];
    u2[m] = dense_u_[m];
  }
  // Groups only when a row has a whole group of zeros between two segments. A row of one segment
  // (a landmark seen from its host frame to the newest, extrinsics constant) would only skip the
  // tiles above its first row, and on the estimator's windows those rows start at the front's
  // first column: the bookkeeping would cost more than it saves (dense_schur.hpp).
  std::uint64_t groups[kDenseSchurRows];  // the columns' groups of 4 each row reaches
  if (dense_gaps_)
    for (int m = 0; m < n; ++m) {
      const int l = dense_lm_[m];
      groups[m] = 0;
      for (int a = lm_seg_begin_[l]; a < lm_seg_begin_[l + 1]; ++a)
        groups[m] |= dense_schur_groups(seg_row_[a], seg_row_[a] + seg_len_[a]);
    }
  dense_schur_update(S.data(), S.outerStride(), n_front_,
                     DenseSchurRows{n, v, u2, dense_lo_, dense_gaps_ ? groups : nullptr});
  dense_gaps_ = false;
}

// rhs -= c v over 1-dof landmark l's segments (c = w g_l).
void Problem::subtract_landmark1_gradient(int l, double c, DenseVector& rhs) const {
  for (int a = lm_seg_begin_[l]; a < lm_seg_begin_[l + 1]; ++a) {
    const double* src = v_ + seg_v_[a];
    double* y = rhs.data() + seg_row_[a];
    for (int t = 0; t < seg_len_[a]; ++t) y[t] -= c * src[t];
  }
}

// Landmark l's couplings as dense row m (v, u = w v, zero between and around its segments), and
// its gradient term out of rhs (subtract_landmark1_gradient).
void Problem::gather_dense_row(int l, double w, int m, DenseVector& rhs) {
  double* v = dense_v_[m];
  double* u = dense_u_[m];
  subtract_landmark1_gradient(l, w * gl_[l][0], rhs);
  const int s0 = lm_seg_begin_[l], s1 = lm_seg_begin_[l + 1];
  int at = 0;
  for (int a = s0; a < s1; ++a) {
    const int oa = seg_row_[a], la = seg_len_[a];
    // A whole group of 4 columns between this segment and the last: the tiles can skip the row there.
    if (a > s0 && dense_schur_group(oa) > dense_schur_group(at - 1) + 1) dense_gaps_ = true;
    const double* src = v_ + seg_v_[a];
    for (; at < oa; ++at) v[at] = u[2 * at] = u[2 * at + 1] = 0.0;
    for (int t = 0; t < la; ++t) {
      v[oa + t] = src[t];
      u[2 * (oa + t)] = u[2 * (oa + t) + 1] = w * src[t];
    }
    at = oa + la;
  }
  for (; at < n_front_; ++at) v[at] = u[2 * at] = u[2 * at + 1] = 0.0;
  dense_lo_[m] = s1 > s0 ? seg_row_[s0] : n_front_;
  dense_lm_[m] = l;
}

// 2- or 3-dof landmark l: W = (H_ll + D)^-1 by a small LLT, kept in winv_ (dl_[l][0] = 0), or
// dl_[l][0] = inf when not positive definite; false then.
bool Problem::invert_landmark_block(int l, double lm_scale, bool damp) {
  const int e = lm_dim_[l];
  Small Hd(e, e);
  for (int p = 0; p < e; ++p)
    for (int q = 0; q < e; ++q) Hd(p, q) = Hll_[l][p * e + q];
  if (damp)
    for (int p = 0; p < e; ++p) {
      const double s2 = scale_l_[l][p] * scale_l_[l][p];
      Hd(p, p) += lm_scale * std::clamp(Hd(p, p) * s2, min_diag_, max_diag_) / s2;
    }
  Eigen::LLT<Small> llt(Hd);
  if (llt.info() != Eigen::Success) {
    dl_[l][0] = std::numeric_limits<double>::infinity();
    return false;
  }
  Small W = Small::Identity(e, e);
  llt.solveInPlace(W);
  // Keep W for back-substitution (dl_ holds a flag only).
  for (int p = 0; p < e; ++p)
    for (int q = 0; q < e; ++q) winv_[l][p * e + q] = W(p, q);
  dl_[l][0] = 0.0;
  return true;
}

namespace {

using VMap = Eigen::Map<const Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor,
                                            capacity::kMaxBlockTangentSize, 3>>;
// winv_[l], row-major as invert_landmark_block writes it.
using WMap = Eigen::Map<const Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor, 3, 3>>;

}  // namespace

// rhs -= V W g over landmark l's couplings (W in winv_), coupling after coupling.
void Problem::subtract_landmark_block_gradient(int l, DenseVector& rhs) const {
  const int e = lm_dim_[l];
  const WMap W(winv_[l], e, e);
  SmallVector g(e);
  for (int p = 0; p < e; ++p) g[p] = gl_[l][p];
  const SmallVector wg = W * g;
  for (int a = lm_cpl_begin_[l]; a < lm_cpl_begin_[l + 1]; ++a) {
    const VMap Va(v_ + cpl_v_[a], cpl_dim_[a], e);
    rhs.segment(cpl_row_[a], cpl_dim_[a]) -= Va.lazyProduct(wg);
  }
}

// 2- or 3-dof landmark: W = (H_ll + D)^-1 (invert_landmark_block), rhs -= V W g and
// S -= V W V^T over its couplings.
void Problem::eliminate_landmark_block(int l, double lm_scale, MatrixMap S, DenseVector& rhs,
                                       bool damp) {
  if (!invert_landmark_block(l, lm_scale, damp)) return;
  subtract_landmark_block_gradient(l, rhs);
  const int e = lm_dim_[l];
  const int c0 = lm_cpl_begin_[l];
  const int c1 = lm_cpl_begin_[l + 1];
  const WMap W(winv_[l], e, e);
  for (int a = c0; a < c1; ++a) {
    const int oa = cpl_row_[a];
    const int da = cpl_dim_[a];
    const VMap Va(v_ + cpl_v_[a], da, e);
    const Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, 0, capacity::kMaxBlockTangentSize, 3>
        VW = Va.lazyProduct(W);
    for (int b = a; b < c1; ++b) {
      const VMap Vb(v_ + cpl_v_[b], cpl_dim_[b], e);
      S.block(oa, cpl_row_[b], da, cpl_dim_[b]) -= VW.lazyProduct(Vb.transpose());
    }
  }
}

// dl = -(H_ll + D_l)^-1 (g_l + V^T dx) for landmark l (not skipped by the elimination).
void Problem::back_substitute(int l) {
  const int e = lm_dim_[l];
  double t[3];
  for (int p = 0; p < e; ++p) t[p] = gl_[l][p];
  if (e == 1) {
    // 1-dof landmark: dot products over its merged contiguous segments.
    for (int a = lm_seg_begin_[l]; a < lm_seg_begin_[l + 1]; ++a)
      t[0] += Eigen::Map<const Eigen::VectorXd>(v_ + seg_v_[a], seg_len_[a])
                  .dot(dx_.segment(seg_row_[a], seg_len_[a]));
    dl_[l][0] = -dl_[l][0] * t[0];
    return;
  }
  for (int a = lm_cpl_begin_[l]; a < lm_cpl_begin_[l + 1]; ++a) {
    const int oa = cpl_row_[a];
    const int da = cpl_dim_[a];
    const double* va = v_ + cpl_v_[a];
    for (int i = 0; i < da; ++i)
      for (int p = 0; p < e; ++p) t[p] += va[i * e + p] * dx_[oa + i];
  }
  for (int p = 0; p < e; ++p) {
    double s = 0.0;
    for (int q = 0; q < e; ++q) s += winv_[l][p * e + q] * t[q];
    dl_[l][p] = -s;
  }
}

// Landmark l's terms of g^T dx and dx^T D dx.
void Problem::add_landmark_model_terms(int l, double lm_scale, bool damp, double* gdx,
                                       double* dDd) const {
  const int e = lm_dim_[l];
  for (int p = 0; p < e; ++p) {
    *gdx += gl_[l][p] * dl_[l][p];
    if (damp) {
      const double s2 = scale_l_[l][p] * scale_l_[l][p];
      *dDd += dl_[l][p] * dl_[l][p] * lm_scale *
              std::clamp(Hll_[l][p * e + p] * s2, min_diag_, max_diag_) / s2;
    }
  }
}

// S = [A B; B^T C] with A the landmark-coupled front rows and C the tail. When C is sparse (the
// IMU chain makes it block-tridiagonal) it is eliminated first: C = U^T U by an envelope Cholesky,
// X = U^-T B^T, A' = A - X^T X (dense rank update), A' factored by cholesky_upper
// (dense_cholesky.hpp). The dense factorization then runs on the front rows only (72 instead of
// 171 in the VIO window). Everything is in place in S's upper triangle: U over C, X^T over B.
bool Problem::factor_reduced_system() {
  MatrixMap S = S_.m();
  if (!split_) return cholesky_upper(S.data(), S.outerStride(), n_red_);
  if (!factor_tail()) return false;
  subtract_tail_products();
  // The dense Cholesky of the front rows.
  return cholesky_upper(S.data(), S.outerStride(), n_front_);
}

// S_ dx_ = -rhs_ from S_'s factor (factor_reduced_system).
bool Problem::solve_factored() {
  MatrixMap S = S_.m();
  if (!split_) {
    dx_ = -rhs_;
    cholesky_solve_upper(S.data(), S.outerStride(), n_red_, dx_.data());
    return dx_.allFinite();
  }
  solve_tail_forward();
  cholesky_solve_upper(S.data(), S.outerStride(), n_front_, dx_.data());
  solve_tail_backward();
  return dx_.allFinite();
}

// A' = A - X^T X on the upper triangle over the rows where X's columns can be non-zero
// (tail_front_first_: a staircase when the tail is an IMU chain, order_tail), four tail columns
// per pass over A. Each entry still takes the columns' terms one after the other in column order
// (a column's rows above its own first row hold exact zeros): the same doubles as one column at a
// time.
void Problem::subtract_tail_products() {
  MatrixMap S = S_.m();
  const int nf = n_front_;
  const Eigen::Index ld = S.outerStride();
  double* s = S.data();
  for (int j = nf; j < n_red_; j += 4) {
    const int g = std::min(4, n_red_ - j);
    int lo = nf;
    for (int c = 0; c < g; ++c) lo = std::min(lo, tail_front_first_[j + c]);
    const double* x[4];  // the columns from row lo on
    for (int c = 0; c < g; ++c) x[c] = s + (j + c) * ld + lo;
    for (int q = lo; q < nf; ++q) {
      double w[4];
      for (int c = 0; c < g; ++c) w[c] = x[c][q - lo];
      sub_scaled_sum(s + q * ld + lo, g, w, x, q - lo + 1);  // rows lo..q of column q
    }
  }
}

// Envelope Cholesky of C (up-looking, column by column): U(i,j) for env_first_[j] <= i <= j, and
// X^T over B. false: C is not positive definite.
bool Problem::factor_tail() {
  MatrixMap S = S_.m();
  const int nf = n_front_;
  const int n = n_red_;
  const Eigen::Index ld = S.outerStride();
  double* s = S.data();
  auto col = [s, ld](int j) { return s + j * ld; };
  for (int j = nf; j < n; ++j) {
    double* cj = col(j);
    const int fj = env_first_[j];
    for (int i = fj; i < j; ++i) {
      const double* ci = col(i);
      const int k0 = std::max(fj, env_first_[i]);
      double d = cj[i];
      for (int k = k0; k < i; ++k) d -= ci[k] * cj[k];
      cj[i] = d / ci[i];
    }
    double d = cj[j];
    for (int k = fj; k < j; ++k) d -= cj[k] * cj[k];
    if (!(d > 0.0)) return false;
    cj[j] = std::sqrt(d);
    // X^T column j (rows 0..nf): (B^T(j,:) - sum_k U(k,j) X(k,:)) / U(j,j). Up to four columns
    // k with the same first row at a time; every row still takes the terms in k order.
    for (int k = fj; k < j;) {
      const int r0 = tail_front_first_[k];
      double u[4];
      const double* xk[4];
      int m = 0;
      for (; m < 4 && k < j && tail_front_first_[k] == r0; ++m, ++k) {
        u[m] = cj[k];
        xk[m] = col(k) + r0;
      }
      if (r0 < nf) sub_scaled_sum(cj + r0, m, u, xk, nf - r0);
    }
    const double inv = 1.0 / cj[j];
    for (int r = tail_front_first_[j]; r < nf; ++r) cj[r] *= inv;
  }
  return true;
}

// y = U^-T rc (kept in dx_'s tail), then dx_'s front = -(ra - X^T y), the right-hand side of A'.
void Problem::solve_tail_forward() {
  const MatrixMap S = S_.m();
  const int nf = n_front_;
  const int n = n_red_;
  const Eigen::Index ld = S.outerStride();
  const double* s = S.data();
  auto col = [s, ld](int j) { return s + j * ld; };
  double* x = dx_.data();
  for (int j = nf; j < n; ++j) {
    const double* cj = col(j);
    double d = rhs_[j];
    for (int k = env_first_[j]; k < j; ++k) d -= cj[k] * x[k];
    x[j] = d / cj[j];
  }
  for (int r = 0; r < nf; ++r) x[r] = -rhs_[r];
  for (int j = nf; j < n; ++j) {
    const double* cj = col(j);
    const double y = x[j];
    for (int r = tail_front_first_[j]; r < nf; ++r) x[r] += cj[r] * y;
  }
}

// xc = -U^-1 (y + X xa), given xa in dx_'s front and y in its tail.
void Problem::solve_tail_backward() {
  const MatrixMap S = S_.m();
  const int nf = n_front_;
  const int n = n_red_;
  const Eigen::Index ld = S.outerStride();
  const double* s = S.data();
  auto col = [s, ld](int j) { return s + j * ld; };
  double* x = dx_.data();
  for (int j = nf; j < n; ++j) {
    const double* cj = col(j);
    double d = x[j];
    for (int r = tail_front_first_[j]; r < nf; ++r) d += cj[r] * x[r];
    x[j] = -d;
  }
  for (int j = n - 1; j >= nf; --j) {
    const double* cj = col(j);
    x[j] /= cj[j];
    const double xj = x[j];
    for (int k = env_first_[j]; k < j; ++k) x[k] -= cj[k] * xj;
  }
}

double Problem::gradient_max_norm() const {
  // Ceres' measure: |x - Plus(x, -g)|_inf in ambient coordinates.
  double m = 0.0;
  double xp[capacity::kMaxBlockAmbientSize];
  double ng[capacity::kMaxBlockTangentSize];
  for (int i = 0; i < num_blocks_; ++i) {
    const Block& b = blocks_[i];
    if (b.constant) continue;
    for (int j = 0; j < b.tangent; ++j)
      ng[j] = b.eliminate ? -gl_[b.index][j] : -b_[b.index + j];
    manifold_plus(b.manifold, b.ambient, b.x, ng, xp);
    for (int j = 0; j < b.ambient; ++j) m = std::max(m, std::abs(b.x[j] - xp[j]));
  }
  return m;
}

double Problem::variable_x_norm() const {
  double s = 0.0;
  for (int i = 0; i < num_blocks_; ++i) {
    const Block& b = blocks_[i];
    if (b.constant) continue;
    for (int j = 0; j < b.ambient; ++j) s += b.x[j] * b.x[j];
  }
  return std::sqrt(s);
}

}  // namespace ums::solver
