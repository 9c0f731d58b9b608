#pragma once
// Options of one nonlinear solve. The defaults equal Ceres 2.1's Solver::Options defaults for
// Levenberg-Marquardt, so a side-by-side run matches step for step (docs/solver.md).

namespace ums::solver {

enum class Method : unsigned char {
  kLevenbergMarquardt = 0,  // Ceres-identical trust region LM (Marquardt diagonal, Nielsen update)
  kGaussNewton,             // undamped steps, every finite step accepted
};

struct SolverOptions {
  Method method = Method::kLevenbergMarquardt;
  int max_iterations = 50;            // count; step attempts (accepted or not), as Ceres counts
  double max_time_s = 1e9;            // s; wall-time budget, checked before each step
  double function_tolerance = 1e-6;   // 1; stop when |cost change| <= tol * cost
  double gradient_tolerance = 1e-10;  // cost units per tangent unit; max-norm of the gradient
  double parameter_tolerance = 1e-8;  // 1; stop when |dx| <= tol * (|x| + tol) (ambient norms)
  double initial_trust_region_radius = 1e4;  // 1 / LM lambda at start
  double max_trust_region_radius = 1e16;
  double min_trust_region_radius = 1e-32;    // below it: converged (no progress possible)
  double min_lm_diagonal = 1e-6;             // clamp of diag(J^T J) used for damping
  double max_lm_diagonal = 1e32;
  double min_relative_decrease = 1e-3;       // accept a step when actual/predicted decrease > this
  int max_consecutive_invalid_steps = 5;     // count; then kNumericalFailure
  bool jacobi_scaling = true;  // damp in Ceres' column-scaled coordinates (1 / (1 + |J_col|))
  // 1; not in Ceres, 0 turns it off (LM only). A step whose model predicts a cost change below
  // predicted_stop_share * function_tolerance * cost ends the solve without the cost pass that
  // Ceres spends on it: Ceres would discard it under function_tolerance unless its actual change
  // were more than 1 / predicted_stop_share times the predicted one (docs/solver.md).
  double predicted_stop_share = 0.0;
  // count; not in Ceres, 0 turns it off. After this many accepted steps the solve ends
  // (Termination::kMaxSuccessfulSteps, status kMaxIterations) without linearizing at the last
  // one: a sliding window's next solve starts from there anyway, and that linearization is most
  // often spent only on finding that the next step is too small to take (docs/solver.md).
  int max_successful_steps = 0;
  // Not in Ceres, false turns it off. At the first accepted step only the gradient J^T r is
  // formed again (Jacobians evaluated there); the Gauss-Newton matrix stays the first one until
  // the next accepted step, whose linearization is whole. Steps, models and tests are as before
  // with that matrix, and the solve still stops where the true gradient vanishes. A warm-started
  // window solve most often ends after that second step (or on finding it too small), and half of
  // a linearization is the J^T J sums and the landmark couplings (docs/solver.md).
  bool reuse_gauss_newton_matrix = false;
  // Not in Ceres; false turns it off (for comparison). When accepting the candidate would run
  // that gradient pass, the candidate's cost comes from the pass itself instead of a cost pass
  // before it: one sweep over the residuals fewer per solve, and the iterate's gradient put back
  // when the candidate is refused. The same bits as off, for residuals whose values do not depend
  // on which Jacobians are wanted (docs/solver.md).
  bool gradient_pass_on_candidate = true;
  // Not in Ceres; false turns it off. When accepting the candidate would linearize it whole next,
  // and the step looks like one to accept (the last candidate was not refused, and its model
  // change is well above what the function tolerance discards), the candidate's cost comes from
  // that whole linearization, run before the decision, instead of from a cost pass before it. A
  // candidate that is then not taken costs a linearization at the iterate again, which gives its
  // system back bit for bit. The same bits as off, for residuals whose values do not depend on
  // which Jacobians are wanted (docs/solver.md, "The candidate's whole pass").
  bool whole_pass_on_candidate = true;
  // Not in Ceres; false turns it off. The step right after reuse_gauss_newton_matrix's gradient
  // pass is solved with the factor of the step before: the matrix is the same, and only the
  // damping would differ. When the trust region grew at the acceptance (a well predicted step)
  // that step takes the earlier, larger damping instead, and costs a back-substitution instead
  // of a Schur complement and its factorization (docs/solver.md, "The kept factorization").
  bool reuse_factorization = false;

  bool validate() const {
    return max_iterations >= 0 && max_time_s > 0.0 && function_tolerance >= 0.0 &&
           gradient_tolerance >= 0.0 && parameter_tolerance >= 0.0 &&
           initial_trust_region_radius > 0.0 &&
           max_trust_region_radius >= initial_trust_region_radius &&
           min_trust_region_radius >= 0.0 && min_lm_diagonal > 0.0 &&
           max_lm_diagonal >= min_lm_diagonal && min_relative_decrease >= 0.0 &&
           max_consecutive_invalid_steps > 0 && predicted_stop_share >= 0.0 &&
           predicted_stop_share <= 1.0 && max_successful_steps >= 0;
  }
};

enum class Termination : unsigned char {
  kNone = 0,
  kFunctionTolerance,
  kParameterTolerance,
  kPredictedFunctionTolerance,  // the step's model change ended the solve (predicted_stop_share)
  kGradientTolerance,
  kMinTrustRegionRadius,
  kMaxIterations,
  kMaxSuccessfulSteps,  // SolverOptions::max_successful_steps steps were accepted
  kTimeBudget,
  kFailure,
};

struct SolverSummary {
  double initial_cost = 0.0;  // 0.5 * sum rho(|r|^2) + priors, at the start
  double final_cost = 0.0;    // same, at the returned state
  int iterations = 0;         // completed step attempts (= Ceres' summary.iterations.size() - 1)
  int successful_steps = 0;
  int linearizations = 0;     // Jacobian evaluations of the whole problem (a candidate's whole pass
                              // not taken included)
  int gradient_passes = 0;    // of them, gradient only (reuse_gauss_newton_matrix)
  int factor_reuses = 0;      // valid steps solved with the factor of the step before (reuse_factorization),
                              // the one a predicted stop ends on included
  int residual_passes = 0;    // sweeps over the residuals: linearizations, gradient passes, candidates' costs
  Termination termination = Termination::kNone;
  double solve_time_s = 0.0;  // s; wall time inside solve()
};

}  // namespace ums::solver
