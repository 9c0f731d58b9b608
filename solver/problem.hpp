#pragma once
// A fixed-memory nonlinear least-squares problem and its solver (docs/solver.md):
//
//   minimize  sum_k 0.5 * rho_k(|r_k(x)|^2)  +  sum_p 0.5 * |r0_p + J_p (x [-] x_lin_p)|^2
//
// over parameter blocks on manifolds. Blocks marked "eliminate" (landmarks: 1-dof inverse depths,
// or any block of up to 3 dofs) are removed by a Schur complement landmark by landmark while the
// system is accumulated; the reduced system over the other blocks (poses, speed-biases,
// extrinsics, time offset: up to capacity::kMaxReducedDim) is dense and solved by an in-place
// Cholesky factorization; landmarks are back-substituted. Iterations are Levenberg-Marquardt with
// exactly Ceres 2.1's trust-region logic (Marquardt diagonal, Jacobi scaling, Nielsen radius update,
// gain-ratio acceptance, its tolerance tests and their order) or plain Gauss-Newton.
//
// Parameter values stay in caller memory (a block is a pointer to its ambient values); the solver
// writes the optimized values there. Set-up (add_*) may be repeated after clear(); solve(),
// evaluate_cost() and marginalize() allocate nothing. The object is large (about 4 MB at the
// capacities of solver/capacity.hpp): create it once at start-up, never on a small stack.

#include <Eigen/Cholesky>
#include <Eigen/Core>
#include <Eigen/Eigenvalues>
#include <cstdint>
#include <initializer_list>

#include "solver/capacity.hpp"
#include "solver/evaluation_callback.hpp"
#include "solver/loss.hpp"
#include "solver/manifold.hpp"
#include "solver/marginal_prior.hpp"
#include "solver/residual.hpp"
#include "solver/solver_options.hpp"
#include "solver/status.hpp"

namespace ums::solver {

using BlockId = int;
inline constexpr BlockId kInvalidBlock = -1;

class Problem {
 public:
  Problem() = default;
  Problem(const Problem&) = delete;
  Problem& operator=(const Problem&) = delete;

  // Forgets every block, residual and prior (memory is kept).
  void clear();

  // ---- set-up ---------------------------------------------------------------------------------
  // A block over caller memory `values` (ambient_size doubles, must stay valid until clear()).
  // eliminate = true: a landmark-like block removed by the Schur complement (tangent <= 3).
  // Returns kInvalidInput on NaN/Inf values or bad sizes, kFull above capacity.
  SolverStatus add_parameter_block(double* values, int ambient_size, ManifoldType manifold,
                                   bool eliminate, BlockId* id);
  // Pose or extrinsic: 7 doubles [p, q.x, q.y, q.z, q.w], 6-dof tangent (manifold.hpp).
  SolverStatus add_pose_block(double* values, BlockId* id) {
    return add_parameter_block(values, kPoseAmbientSize, ManifoldType::kPose, false, id);
  }
  // Speed-bias (9), time offset (1), any vector kept in the reduced system.
  SolverStatus add_euclidean_block(double* values, int size, BlockId* id) {
    return add_parameter_block(values, size, ManifoldType::kEuclidean, false, id);
  }
  // Inverse depth (1) or another small block eliminated per landmark.
  SolverStatus add_landmark_block(double* values, int size, BlockId* id) {
    return add_parameter_block(values, size, ManifoldType::kEuclidean, true, id);
  }
  // A constant block keeps its value; residuals still read it.
  SolverStatus set_constant(BlockId id, bool constant);
  bool is_constant(BlockId id) const { return blocks_[id].constant; }
  int num_blocks() const { return num_blocks_; }
  int num_residuals() const { return num_residuals_; }

  // A residual over blocks ids[0..n) (in the order fn->evaluate expects them). At most one of them
  // may be an eliminated block. `fn` must stay valid until clear().
  SolverStatus add_residual(const ResidualFunction* fn, const RobustLoss& loss, const BlockId* ids,
                            int n);
  SolverStatus add_residual(const ResidualFunction* fn, const RobustLoss& loss,
                            std::initializer_list<BlockId> ids) {
    return add_residual(fn, loss, ids.begin(), static_cast<int>(ids.size()));
  }
  // Landmark `landmark` is seen through lift's point (residual.hpp, PointLift): p(host, landmark,
  // others[0..n_others)). Its residuals that support point Jacobians and read host get them while
  // host and landmark are variable (a 6-dof host, a 1-dof landmark); the others, and every
  // residual otherwise, are linearized as usual. Results agree with the plain linearization to
  // rounding. `lift` must stay valid until clear().
  SolverStatus set_point_lift(const PointLift* lift, BlockId host, BlockId landmark, const BlockId* others,
                              int n_others);
  // A marginalization prior over ids[i] <-> prior->block(i) (same manifold and size; no eliminated
  // blocks). `prior` must stay valid and unchanged until clear().
  SolverStatus add_prior(const MarginalPrior* prior, const BlockId* ids);

  // Runs before every evaluation pass (evaluation_callback.hpp); nullptr: none. Kept by clear().
  void set_evaluation_callback(EvaluationCallback* callback) { callback_ = callback; }

  // ---- solving ----------------------------------------------------------------------------------
  // Minimizes from the current values. kInvalidInput if a value or the initial residuals/Jacobians
  // are not finite (nothing is changed then); otherwise usable(status) tells whether the values
  // written back are a valid estimate (the last accepted iterate).
  SolverStatus solve(const SolverOptions& options, SolverSummary* summary);
  // Total cost at the current values (kInvalidInput when not finite).
  SolverStatus evaluate_cost(double* cost);
  // A check of residuals after a solve (outliers) need not evaluate them again: the pass that
  // visited the values solve() returned kept them. True when they are known: the last solve was
  // usable and neither the problem nor a variable block's value has changed since (the values are
  // compared, so this costs one pass over the blocks). Constant blocks and the residual objects'
  // own state are not compared: the caller must not have changed them since the solve.
  bool solved_residuals_current() const;
  // Residual k's values (before the robust loss, as its function wrote them) at the values solve()
  // returned; valid while solved_residuals_current(). nullptr when k was not kept: every block of
  // it constant, or past capacity::kMaxKeptResidualRows.
  const double* solved_residual(int k) const {
    return kept_off_[k] < 0 ? nullptr : kept_[kept_cur_] + kept_off_[k];
  }

  // Marginalizes blocks ids[0..n): every residual and prior touching them is linearized at the
  // current values (robust weights included), their landmarks and the listed blocks are removed by
  // Schur complement, and the result over the remaining connected blocks is written to *out in
  // square-root form with x_lin = current values. Eliminated blocks touched by those residuals
  // must be in the list. out->block(i).source_id are ids of this problem. kSingular if a
  // marginalized block carries no information at all.
  SolverStatus marginalize(const BlockId* ids, int n, MarginalPrior* out);
  // The blocks marginalize() will probably be given after the coming solve (the same list, any
  // order). Every linearization then sums the terms of the listed landmarks' residuals
  // apart before adding them to H, and marginalize() with exactly those landmarks takes them
  // instead of evaluating the residuals again, when the problem and every block's value (constant
  // ones too, bit for bit) are those of the last linearization; otherwise it linearizes as
  // without a hint. The prior agrees with the unhinted one to rounding (docs/solver.md,
  // "Marginalization"), unless the last linearization was a gradient pass
  // (reuse_gauss_newton_matrix): then its information is that of the whole one before. As for
  // solved_residuals_current(), the residual objects' own state must
  // not change in between. Kept until clear(); n = 0 removes it.
  SolverStatus set_marginalization_hint(const BlockId* ids, int n);
  // The caller moved pose blocks ids[0..n) together since the last linearization, by one rigid
  // transform of their world frame (p' = R p + t, q' = R q). The kept terms follow: in the
  // tangent p' = R p the Jacobians' position columns are J R^T, so those rows and columns of H,
  // b and V are rotated by R, and the moved values become the ones the terms were taken at. A
  // move that was not rigid (1e-9 relative) or not by R drops the terms. Every world-frame pose
  // the hinted landmarks' residuals read must be listed, moved or not (one left in place then
  // fails the check); body-frame poses (extrinsics) are not listed, and any other block that
  // changed is caught by marginalize()'s comparison. kInvalidInput: a bad or repeated id, or a
  // block that is not a pose.
  SolverStatus note_world_moved(const BlockId* ids, int n, const Eigen::Matrix3d& R);
  // The last marginalize() took the kept terms (for statistics and tests).
  bool marginalization_reused() const { return marg_reused_; }

  // Reduced-system layout after a solve/marginalize (for diagnostics and tests): first row of a
  // variable non-eliminated block in the reduced system, or -1.
  int reduced_offset(BlockId id) const { return blocks_[id].eliminate ? -1 : blocks_[id].index; }
  int reduced_dim() const { return n_red_; }
  // The gradient J^T r of the solve's last linearization (whole or gradient pass), for tests: the
  // reduced rows' (reduced_dim() values) and, per landmark slot, its (up to 3) values.
  double reduced_gradient(int row) const { return b_[row]; }
  int num_landmark_slots() const { return num_lm_; }
  double landmark_gradient(int slot, int k) const { return gl_[slot][k]; }

 private:
  struct Block {
    double* x = nullptr;
    std::int8_t ambient = 0;
    std::int8_t tangent = 0;
    ManifoldType manifold = ManifoldType::kEuclidean;
    bool constant = false;
    bool eliminate = false;
    int index = -1;  // reduced: row offset; eliminated: landmark slot; -1 when constant
    std::int16_t lift = -1;  // eliminated: its entry in lifts_, or -1
  };
  struct LiftRef {
    const PointLift* fn = nullptr;
    std::int16_t blocks[capacity::kMaxBlocksPerResidual] = {};  // host, landmark, others
    std::int8_t num_blocks = 0;
  };
  struct Residual {
    const ResidualFunction* fn = nullptr;
    RobustLoss loss;
    std::int16_t blocks[capacity::kMaxBlocksPerResidual] = {};
    std::int16_t slot[capacity::kMaxBlocksPerResidual] = {};  // coupling index per reduced block
    std::int8_t num_blocks = 0;
    std::int8_t rows = 0;
    std::int16_t landmark = -1;  // landmark slot of its variable eliminated block, or -1
    bool fixed = false;          // every block constant: cost only, once per solve
    bool fast2 = false;          // 2 rows over 6-dof reduced blocks (+ one 1-dof landmark)
    std::int8_t num_sorted = 0;  // variable reduced blocks, positions sorted by reduced row
    std::int8_t sorted[capacity::kMaxBlocksPerResidual] = {};
    std::int8_t lm_pos = -1;     // position of the variable eliminated block, or -1
    std::int8_t lift_pos = -1;   // position of its landmark's lift host when linearized through the point
    bool lm_coupled = false;     // has a variable eliminated block: its variable reduced blocks are all front blocks
    // Cached by prepare(): value pointers, tangent sizes and variable flags of the blocks.
    const double* params[capacity::kMaxBlocksPerResidual] = {};
    std::int8_t tangent[capacity::kMaxBlocksPerResidual] = {};
    bool variable[capacity::kMaxBlocksPerResidual] = {};
  };
  struct PriorRef {
    const MarginalPrior* prior = nullptr;
    std::int16_t blocks[capacity::kMaxReducedBlocks] = {};
    bool fixed = false;
  };

  struct LmState;       // one solve(): trust-region state and summary (problem_solve.cpp)
  struct MarginalRows;  // one marginalize(): its row partition (problem_marginalize.cpp)

  // ---- structure (problem_prepare.cpp) ----
  // Ordering, residual groups, landmark couplings and segments, the tail envelope, workspace sizes.
  SolverStatus prepare();
  void mark_landmark_coupled();
  SolverStatus order_blocks();
  void first_front_rows();
  SolverStatus order_tail();
  void classify_residual(Residual& rb);
  void group_residuals();
  void assign_lifts();
  SolverStatus build_couplings();
  SolverStatus collect_couplings(int l, int* ids, int* n_ids);
  SolverStatus add_couplings(int l, const int* ids, int n_ids, int* v_used);
  void merge_segments(int l, int n_ids);
  void mark_fixed_priors();
  void couple_tail(int ia, int ic);
  void build_tail_envelope();
  void resize_workspace();

  // ---- linearization (problem_linearize.cpp) ----
  // keep (optional): receives the residual's values before the loss corrects them.
  bool evaluate_residual(const Residual& rb, bool jacobians, double* r, double* cost, double* keep = nullptr);
  void accumulate_residual(int res_index, const double* r);
  void accumulate_two_row(const Residual& rb, const double* r);
  void add_blocks_2x6(const Residual& rb, int a, const double* r, int skip);
  // Point-lifted landmarks (problem_lift.cpp): a landmark's sums start, each residual adds
  // A^T A, A^T r, A^T J_c and its other blocks' terms, the end forms the host and landmark terms.
  void begin_lift(int l);
  void accumulate_lifted(const Residual& rb, const double* r);
  void add_lift_sums(const double* A, double r0, double r1);
  bool finish_lift(int l);
  void add_lift_couplings(int l, const double* G);
  bool lift_jacobian(int l, double* G);  // G = d p / d (host, landmark) of landmark l's lift
  bool finish_lift_gradient(int l);      // a gradient pass's lift terms: b_h, g_l from s only
  // A gradient pass (linearize_gradient): b += J^T r, g_l += J_l^T r, a lift's s += A^T r.
  void accumulate_gradient(const Residual& rb, const double* r);
  int accumulate_reduced(const Residual& rb, const double* r);
  void accumulate_landmark1(const Residual& rb, int l, const double* Jl, const double* r);
  void accumulate_landmark(const Residual& rb, int l, const double* Jl, const double* r);
  bool linearize_prior(const PriorRef& p, bool jacobians, double* cost);
  // Zeroes the upper triangle (with the diagonal) of H: the lower one is never read, and the
  // 2 x 6 and prior blocks write some of it.
  static void zero_upper(MatrixMap H);
  void zero_linear_system();
  bool linear_system_finite() const;
  // Landmark l's residuals at the current values (cost into *total, values into kept), with
  // jacobians accumulated (into Hsep_, bsep_ when hinted: hinted_landmark()).
  bool linearize_landmark(int l, bool jacobians, double* total, double* kept);
  // Where residual k's values go in the kept buffer `kept` (nullptr: not kept).
  double* kept_slot(double* kept, int k) const { return kept != nullptr && kept_off_[k] >= 0 ? kept + kept_off_[k] : nullptr; }
  bool hinted_landmark(int l) const { return hint_[lm_block_[l]] && !blocks_[lm_block_[l]].constant; }
  // H_ += Hsep_, b_ += bsep_ over the rows landmarks couple to (upper triangle).
  void add_separated();
  void note_separated_linearization();  // lin_x_, sep_valid_ (after a linearization, whole or gradient)
  // Cost (and, with jacobians, H_, b_, landmark blocks) at the current values; false if not finite.
  // The residuals' values go to kept_[kept_write_] when kept_write_ >= 0.
  bool linearize(bool jacobians, double* cost);
  // linearize(true) forming only the gradient (b, g_l) at the current values: H, H_ll and V stay
  // those of the last whole linearization (SolverOptions::reuse_gauss_newton_matrix).
  bool linearize_gradient(double* cost);
  void assign_kept_rows();  // kept_off_ (prepare())
  void snapshot_solution();  // solved_x_, kept_valid_ (end of solve())
  double fixed_cost();

  // ---- Levenberg-Marquardt (problem_solve.cpp) ----
  bool start_solve(LmState& s);
  void set_jacobi_scaling(bool jacobi);
  bool iterate(LmState& s);
  bool can_continue(LmState& s);
  bool reject_invalid_step(LmState& s);
  bool refresh_matrix(LmState& s);
  double apply_candidate();
  void restore_values();
  bool predicted_converged(LmState& s, double model_change);
  static bool step_small(const LmState& s, double step_norm);  // the parameter tolerance's test
  bool candidate_converged(LmState& s, double step_norm, double cand_cost);
  bool accept_step(LmState& s, double cand_cost, double relative_decrease);
  // The candidate's cost, from the pass that accepting it would run next when there is one (the
  // gradient pass, or a whole linearization when the candidate looks acceptable): one sweep over
  // the residuals instead of two. The iterate's terms come back unless it is accepted.
  bool evaluate_candidate(const LmState& s, double model_change, double step_norm, double* cost);
  bool step_budget_spent(const LmState& s) const;    // accepting uses the last permitted step
  bool last_permitted_step(const LmState& s) const;  // accepting ends the solve unlinearized
  bool gradient_only_at_acceptance(const LmState& s) const;  // reuse_gauss_newton_matrix's pass
  bool gradient_pass_follows(const LmState& s) const;
  bool candidate_takes_gradient_pass(const LmState& s) const;  // ... and the options allow it
  // whole_pass_on_candidate: accepting would linearize whole, and the candidate looks acceptable.
  bool candidate_takes_whole_pass(const LmState& s, double model_change, double step_norm) const;
  void keep_gradient_terms();
  void restore_gradient_terms();
  bool drop_candidate_linearization(LmState& s);  // the candidate is not accepted: the iterate's terms again
  // Solves the damped system (lm_scale = 1/radius; 0 for Gauss-Newton); false on failure. Keeps
  // the factor of the reduced system (factor_valid_, factor_lm_scale_).
  bool compute_step(double lm_scale, double* model_cost_change);
  // The step for the current gradient from the kept factor (SolverOptions::reuse_factorization).
  bool compute_step_kept_factor(double* model_cost_change);
  bool finish_step(double lm_scale, double* model_cost_change);
  void form_reduced_system(double lm_scale, bool damp);
  double invert_landmark1(int l, double lm_scale, bool damp);
  // 1-dof landmarks go in chunks of kDenseSchurRows dense rows (dense_v_, dense_schur.hpp).
  static constexpr int kDenseSchurRows = 32;
  // marginalized: only the landmarks marked in marg_ (the marginalization's).
  void eliminate_all(double lm_scale, MatrixMap S, DenseVector& rhs, bool damp, bool marginalized = false);
  void gather_dense_row(int l, double w, int m, DenseVector& rhs);
  void subtract_landmark1_gradient(int l, double c, DenseVector& rhs) const;
  void flush_dense_rows(int n, MatrixMap S);
  void eliminate_landmark_block(int l, double lm_scale, MatrixMap S, DenseVector& rhs, bool damp);
  bool invert_landmark_block(int l, double lm_scale, bool damp);
  void subtract_landmark_block_gradient(int l, DenseVector& rhs) const;
  // Factors S_ in place (upper triangle read, overwritten); false on failure.
  bool factor_reduced_system();
  bool solve_factored();
  bool factor_tail();
  void subtract_tail_products();
  void solve_tail_forward();
  void solve_tail_backward();
  void back_substitute(int l);
  void add_landmark_model_terms(int l, double lm_scale, bool damp, double* gdx, double* dDd) const;
  double gradient_max_norm() const;
  double variable_x_norm() const;

  // ---- marginalization (problem_marginalize.cpp) ----
  bool touches_marginalized(const Residual& rb) const;
  SolverStatus marginalize_prepared(const BlockId* ids, int n, MarginalPrior* out);
  SolverStatus select_marginalized(const BlockId* ids, int n);
  SolverStatus linearize_marginalized();
  bool separated_current() const;
  bool block_as_linearized(int i) const;
  bool moved_rigidly(const BlockId* ids, int n, const Eigen::Matrix3d& R) const;
  void rotate_separated(const BlockId* ids, int n, const Eigen::Matrix3d& R);
  SolverStatus reuse_marginalized();
  SolverStatus accumulate_marginalized(bool kept);
  bool linearize_marginalized_landmark(int l);
  SolverStatus partition_marginal_rows(MarginalRows* rows);
  void gather_marginal_system(const MarginalRows& rows);
  SolverStatus schur_marginalized(int dm, int dk);

  // Problem definition.
  Block blocks_[capacity::kMaxParameterBlocks];
  int num_blocks_ = 0;
  Residual residuals_[capacity::kMaxResidualBlocks];
  int num_residuals_ = 0;
  PriorRef priors_[capacity::kMaxPriors];
  int num_priors_ = 0;
  LiftRef lifts_[capacity::kMaxEliminatedBlocks];
  int num_lifts_ = 0;
  bool prepared_ = false;
  EvaluationCallback* callback_ = nullptr;

  // Structure built by prepare().
  int n_red_ = 0;
  int num_lm_ = 0;
  std::int16_t lm_block_[capacity::kMaxEliminatedBlocks] = {};
  std::int8_t lm_dim_[capacity::kMaxEliminatedBlocks] = {};
  int lm_res_begin_[capacity::kMaxEliminatedBlocks + 1] = {};
  int lm_res_[capacity::kMaxResidualBlocks] = {};
  int lm_cpl_begin_[capacity::kMaxEliminatedBlocks + 1] = {};
  int free_res_[capacity::kMaxResidualBlocks] = {};
  int num_free_res_ = 0;
  int cpl_row_[capacity::kMaxCouplings] = {};   // reduced row offset of the coupled block
  std::int8_t cpl_dim_[capacity::kMaxCouplings] = {};
  int cpl_v_[capacity::kMaxCouplings] = {};     // offset into v_ of its d x e block (row-major)
  int num_cpl_ = 0;
  // Couplings of one landmark with adjacent rows merged into segments (frames observed in a row
  // are contiguous in the reduced system), so its Schur update is a few dense rank-e updates.
  int lm_seg_begin_[capacity::kMaxEliminatedBlocks + 1] = {};
  int seg_row_[capacity::kMaxCouplings] = {};
  int seg_len_[capacity::kMaxCouplings] = {};
  int seg_v_[capacity::kMaxCouplings] = {};
  int num_seg_ = 0;
  int v_used_ = 0;
  // Rows [0, n_front_) are blocks coupled to landmarks (dense after the Schur complement), rows
  // [n_front_, n_red_) the others (speed-biases, time offsets), usually coupled only along the IMU
  // chain. env_first_[j] (tail columns j): first row >= n_front_ that may be non-zero in column j
  // of the tail block (its envelope, preserved by Cholesky). split_: the tail is sparse enough to
  // be eliminated by an envelope Cholesky before a dense one on the front rows.
  // tail_front_first_[j] (tail columns j): first front row that may be non-zero in column j of
  // the front-tail block, B^T before factor_tail and X^T after it (n_front_: none).
  int n_front_ = 0;
  int env_first_[capacity::kMaxReducedDim] = {};
  int tail_front_first_[capacity::kMaxReducedDim] = {};
  bool split_ = false;
  int mark_[capacity::kMaxParameterBlocks] = {};     // prepare(): last landmark listing a block
  int slot_of_[capacity::kMaxParameterBlocks] = {};  // prepare(): its coupling index there

  // Linearization: reduced H (upper triangle) and b = J^T r; per landmark H_ll, g_l, V = J_B^T J_l.
  DenseMatrix H_;
  DenseVector b_;
  double Hll_[capacity::kMaxEliminatedBlocks][9] = {};
  double gl_[capacity::kMaxEliminatedBlocks][3] = {};
  double v_[capacity::kMaxCouplingEntries] = {};
  // Point lifts: per landmark slot its lift (lifts_ index) when used, else -1; one landmark's sums
  // while it is linearized: S = sum A^T A (3 x 3), s = sum A^T r, X_c = sum A^T J_c (3 x 6 row-major)
  // per coupling of the landmark (local index), and the host's coupling.
  std::int16_t lm_lift_[capacity::kMaxEliminatedBlocks] = {};
  double lift_S_[9] = {};
  double lift_s_[3] = {};
  double lift_X_[capacity::kMaxCouplingsPerLandmark][18] = {};
  bool lift_used_[capacity::kMaxCouplingsPerLandmark] = {};
  int lift_host_slot_ = -1;
  bool gradient_pass_ = false;  // set by linearize_gradient() while it runs
  // evaluate_candidate(): the iterate's gradient terms while the candidate's gradient pass holds
  // b_, g_l, bsep_ and the separated linearization point; candidate_linearized_: that pass ran.
  DenseVector kept_b_;
  DenseVector kept_bsep_;
  double kept_gl_[capacity::kMaxEliminatedBlocks][3] = {};
  double kept_lin_x_[capacity::kMaxParameterBlocks][capacity::kMaxBlockAmbientSize] = {};
  bool kept_sep_valid_ = false;
  bool candidate_linearized_ = false;
  bool iterate_system_spoiled_ = false;  // a whole pass at the candidate replaced the iterate's system
  int residual_passes_ = 0;  // calls of linearize() in this solve (SolverSummary::residual_passes)

  // Step computation.
  DenseMatrix S_;
  DenseVector rhs_;
  DenseVector dx_;
  DenseVector scale_red_;
  DenseVector d_red_;  // LM diagonal of the reduced blocks for the current step
  // S_ holds the factor of this solve's last compute_step, formed with factor_lm_scale_.
  bool factor_valid_ = false;
  double factor_lm_scale_ = 0.0;
  double dl_[capacity::kMaxEliminatedBlocks][3] = {};
  // eliminate_all(): one chunk of landmarks' couplings as dense rows over
  // the front rows, v and u = w v (zero outside the landmark's segments; u's entries doubled into
  // packets), and the first row each can be non-zero in.
  alignas(16) double dense_v_[kDenseSchurRows][capacity::kMaxReducedDim] = {};
  alignas(16) double dense_u_[kDenseSchurRows][2 * capacity::kMaxReducedDim] = {};  // u(j) twice: a packet
  int dense_lo_[kDenseSchurRows] = {};
  int dense_lm_[kDenseSchurRows] = {};  // each row's landmark
  bool dense_gaps_ = false;  // a row gathered since the last flush has a group of zeros between segments
  double winv_[capacity::kMaxEliminatedBlocks][9] = {};  // (H_ll + D)^-1 for e > 1
  double min_diag_ = 1e-6;
  double max_diag_ = 1e32;
  double scale_l_[capacity::kMaxEliminatedBlocks][3] = {};
  double backup_[capacity::kMaxParameterBlocks][capacity::kMaxBlockAmbientSize] = {};

  // Residual values of the iterate (kept_[kept_cur_]) and of the candidate; the values of the
  // variable blocks the last usable solve returned (solved_residuals_current()).
  double kept_[2][capacity::kMaxKeptResidualRows] = {};
  int kept_off_[capacity::kMaxResidualBlocks] = {};
  int kept_cur_ = 0;
  int kept_write_ = -1;
  bool kept_valid_ = false;
  double solved_x_[capacity::kMaxParameterBlocks][capacity::kMaxBlockAmbientSize] = {};

  // Per-residual workspace.
  double jac_ws_[capacity::kMaxBlocksPerResidual]
                [capacity::kMaxResidualSize * capacity::kMaxBlockTangentSize] = {};
  bool jac_wanted_[capacity::kMaxBlocksPerResidual] = {};
  JacobianView jac_view_[capacity::kMaxBlocksPerResidual];
  const JacobianView no_jac_[capacity::kMaxBlocksPerResidual] = {};

  // Marginalization hint: hint_[block] listed; the hinted landmarks' terms of the last full
  // linearization (Hsep_ upper triangle, bsep_, over rows [0, n_front_)), valid (sep_valid_) at
  // the block values lin_x_. acc_H_, acc_b_: where the accumulation writes (H_, b_ or these).
  bool hint_[capacity::kMaxParameterBlocks] = {};
  bool hinted_ = false;
  DenseMatrix Hsep_;
  DenseVector bsep_;
  DenseMatrix* acc_H_ = &H_;
  DenseVector* acc_b_ = &b_;
  bool sep_valid_ = false;
  bool marg_reused_ = false;
  double lin_x_[capacity::kMaxParameterBlocks][capacity::kMaxBlockAmbientSize] = {};

  // Prior / marginalization workspace.
  DenseMatrix M_;
  DenseVector pe_;
  DenseVector pr_;
  bool marg_[capacity::kMaxParameterBlocks] = {};
  // touched_: blocks the marginalization's residuals and priors reach (and, within prepare(), the
  // blocks coupled to landmarks); mark_touched_: set while the marginalization accumulates, so that
  // the solve's passes do not pay for marking.
  bool touched_[capacity::kMaxParameterBlocks] = {};
  bool mark_touched_ = false;
  using MargMatrix = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::ColMajor,
                                   capacity::kMaxMarginalizedDim, capacity::kMaxMarginalizedDim>;
  using KeptMargMatrix = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::ColMajor,
                                       capacity::kMaxReducedDim, capacity::kMaxMarginalizedDim>;
  MargMatrix Hmm_;
  MargMatrix Hmm_inv_;
  KeptMargMatrix Hkm_;
  KeptMargMatrix T_;
  Eigen::SelfAdjointEigenSolver<MargMatrix> eig_;
  PriorBlock prior_blocks_[capacity::kMaxReducedBlocks];
};

}  // namespace ums::solver
