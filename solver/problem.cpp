#include "solver/problem.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>

#include "solver/finite.hpp"

namespace ums::solver {
namespace {

double seconds_since(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

}  // namespace

void Problem::clear() {
  num_blocks_ = 0;
  num_residuals_ = 0;
  num_priors_ = 0;
  prepared_ = false;
}

SolverStatus Problem::add_parameter_block(double* values, int ambient_size, ManifoldType manifold,
                                          bool eliminate, BlockId* id) {
  if (id != nullptr) *id = kInvalidBlock;
  if (values == nullptr || ambient_size <= 0 || ambient_size > capacity::kMaxBlockAmbientSize)
    return SolverStatus::kInvalidInput;
  if (manifold == ManifoldType::kPose && ambient_size != kPoseAmbientSize)
    return SolverStatus::kInvalidInput;
  const int t = tangent_size(manifold, ambient_size);
  if (eliminate && (manifold != ManifoldType::kEuclidean || t > capacity::kMaxEliminatedTangentSize))
    return SolverStatus::kInvalidInput;
  if (!all_finite(values, ambient_size)) return SolverStatus::kInvalidInput;
  if (num_blocks_ >= capacity::kMaxParameterBlocks) return SolverStatus::kFull;
  Block& b = blocks_[num_blocks_];
  b.x = values;
  b.ambient = static_cast<std::int8_t>(ambient_size);
  b.tangent = static_cast<std::int8_t>(t);
  b.manifold = manifold;
  b.constant = false;
  b.eliminate = eliminate;
  b.index = -1;
  if (id != nullptr) *id = num_blocks_;
  ++num_blocks_;
  prepared_ = false;
  return SolverStatus::kOk;
}

SolverStatus Problem::set_constant(BlockId id, bool constant) {
  if (id < 0 || id >= num_blocks_) return SolverStatus::kInvalidInput;
  blocks_[id].constant = constant;
  prepared_ = false;
  return SolverStatus::kOk;
}

SolverStatus Problem::add_residual(const ResidualFunction* fn, const RobustLoss& loss,
                                   const BlockId* ids, int n) {
  if (fn == nullptr || n <= 0 || n > capacity::kMaxBlocksPerResidual)
    return SolverStatus::kInvalidInput;
  const int rows = fn->num_residuals();
  if (rows <= 0 || rows > capacity::kMaxResidualSize) return SolverStatus::kInvalidInput;
  if (!(loss.scale > 0.0) || !std::isfinite(loss.scale)) return SolverStatus::kInvalidInput;
  int eliminated = 0;
  for (int k = 0; k < n; ++k) {
    if (ids[k] < 0 || ids[k] >= num_blocks_) return SolverStatus::kInvalidInput;
    for (int j = 0; j < k; ++j)
      if (ids[j] == ids[k]) return SolverStatus::kInvalidInput;
    if (blocks_[ids[k]].eliminate) ++eliminated;
  }
  if (eliminated > 1) return SolverStatus::kInvalidInput;
  if (num_residuals_ >= capacity::kMaxResidualBlocks) return SolverStatus::kFull;
  Residual& rb = residuals_[num_residuals_++];
  rb.fn = fn;
  rb.loss = loss;
  rb.num_blocks = static_cast<std::int8_t>(n);
  rb.rows = static_cast<std::int8_t>(rows);
  for (int k = 0; k < n; ++k) rb.blocks[k] = static_cast<std::int16_t>(ids[k]);
  prepared_ = false;
  return SolverStatus::kOk;
}

SolverStatus Problem::add_prior(const MarginalPrior* prior, const BlockId* ids) {
  if (prior == nullptr) return SolverStatus::kInvalidInput;
  if (num_priors_ >= capacity::kMaxPriors) return SolverStatus::kFull;
  for (int i = 0; i < prior->num_blocks(); ++i) {
    const PriorBlock& pb = prior->block(i);
    if (ids[i] < 0 || ids[i] >= num_blocks_) return SolverStatus::kInvalidInput;
    const Block& b = blocks_[ids[i]];
    if (b.eliminate || b.manifold != pb.manifold || b.ambient != pb.ambient_size)
      return SolverStatus::kInvalidInput;
  }
  PriorRef& p = priors_[num_priors_++];
  p.prior = prior;
  for (int i = 0; i < prior->num_blocks(); ++i) p.blocks[i] = static_cast<std::int16_t>(ids[i]);
  prepared_ = false;
  return SolverStatus::kOk;
}

// Schur complement of landmark l into S, rhs (rhs = reduced gradient). damp: add its LM diagonal.
void Problem::eliminate_landmark(int l, double lm_scale, MatrixMap S, DenseVector& rhs,
                                 bool damp) {
  const int e = lm_dim_[l];
  const int c0 = lm_cpl_begin_[l];
  const int c1 = lm_cpl_begin_[l + 1];
  if (e == 1) {
    double h = Hll_[l][0];
    if (damp) h += lm_scale * std::clamp(h * scale_l_[l][0] * scale_l_[l][0], min_diag_, max_diag_) /
                   (scale_l_[l][0] * scale_l_[l][0]);
    if (!(h > 0.0)) {
      dl_[l][0] = std::numeric_limits<double>::infinity();  // marks "skipped" for back-substitution
      return;
    }
    const double w = 1.0 / h;
    dl_[l][0] = w;  // keep 1/h for back-substitution
    const double wg = w * gl_[l][0];
    const int s0 = lm_seg_begin_[l];
    const int s1 = lm_seg_begin_[l + 1];
    // S -= w v v^T over the segments' upper triangle, column by column: plain axpy loops on
    // contiguous rows (short, variable lengths: cheaper than Eigen segment expressions).
    const Eigen::Index ld = S.outerStride();
    for (int a = s0; a < s1; ++a) {
      const int oa = seg_row_[a];
      const int la = seg_len_[a];
      const double* va = v_ + seg_v_[a];
      double* rhs_a = rhs.data() + oa;
      for (int i = 0; i < la; ++i) rhs_a[i] -= wg * va[i];
      for (int j = 0; j < la; ++j) {
        double* col = S.data() + (oa + j) * ld + oa;
        const double cj = w * va[j];
        for (int i = 0; i <= j; ++i) col[i] -= cj * va[i];
      }
      for (int b = a + 1; b < s1; ++b) {
        const int ob = seg_row_[b];
        const int lb = seg_len_[b];
        const double* vb = v_ + seg_v_[b];
        for (int j = 0; j < lb; ++j) {
          double* col = S.data() + (ob + j) * ld + oa;
          const double cj = w * vb[j];
          for (int i = 0; i < la; ++i) col[i] -= cj * va[i];
        }
      }
    }
    return;
  }
  Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, 0, 3, 3> Hd(e, e);
  for (int p = 0; p < e; ++p)
    for (int q = 0; q < e; ++q) Hd(p, q) = Hll_[l][p * e + q];
  if (damp)
    for (int p = 0; p < e; ++p) {
      const double s2 = scale_l_[l][p] * scale_l_[l][p];
      Hd(p, p) += lm_scale * std::clamp(Hd(p, p) * s2, min_diag_, max_diag_) / s2;
    }
  Eigen::LLT<Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, 0, 3, 3>> llt(Hd);
  if (llt.info() != Eigen::Success) {
    dl_[l][0] = std::numeric_limits<double>::infinity();
    return;
  }
  Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, 0, 3, 3> W =
      Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, 0, 3, 3>::Identity(e, e);
  llt.solveInPlace(W);
  // Keep W for back-substitution in Hll_ workspace of the step (dl_ holds a flag only).
  for (int p = 0; p < e; ++p)
    for (int q = 0; q < e; ++q) winv_[l][p * e + q] = W(p, q);
  dl_[l][0] = 0.0;
  Eigen::Matrix<double, Eigen::Dynamic, 1, 0, 3, 1> g(e);
  for (int p = 0; p < e; ++p) g[p] = gl_[l][p];
  const Eigen::Matrix<double, Eigen::Dynamic, 1, 0, 3, 1> wg = W * g;
  using VMap = Eigen::Map<const Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic,
                                              Eigen::RowMajor, capacity::kMaxBlockTangentSize, 3>>;
  for (int a = c0; a < c1; ++a) {
    const int oa = cpl_row_[a];
    const int da = cpl_dim_[a];
    const VMap Va(v_ + cpl_v_[a], da, e);
    rhs.segment(oa, da) -= Va.lazyProduct(wg);
    const Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, 0, capacity::kMaxBlockTangentSize, 3>
        VW = Va.lazyProduct(W);
    for (int b = a; b < c1; ++b) {
      const VMap Vb(v_ + cpl_v_[b], cpl_dim_[b], e);
      S.block(oa, cpl_row_[b], da, cpl_dim_[b]) -= VW.lazyProduct(Vb.transpose());
    }
  }
}

bool Problem::compute_step(double lm_scale, double* model_cost_change) {
  const bool damp = lm_scale > 0.0;
  // Only the upper triangle is ever read (Schur updates and the Upper LLT).
  S_.m().triangularView<Eigen::Upper>() = H_.m();
  rhs_ = b_;
  if (damp) {
    MatrixMap S = S_.m();
    const ConstMatrixMap H = static_cast<const DenseMatrix&>(H_).m();
    for (int i = 0; i < n_red_; ++i) {
      const double s2 = scale_red_[i] * scale_red_[i];
      d_red_[i] = lm_scale * std::clamp(H(i, i) * s2, min_diag_, max_diag_) / s2;
      S(i, i) += d_red_[i];
    }
  }
  for (int l = 0; l < num_lm_; ++l) eliminate_landmark(l, lm_scale, S_.m(), rhs_, damp);

  if (n_red_ > 0 && !factor_and_solve()) return false;

  // Back-substitution and the model decrease -(g^T dx + 0.5 dx^T H dx), computed from the damped
  // normal equations (H + D) dx = -g as -0.5 g^T dx + 0.5 dx^T D dx.
  double gdx = b_.dot(dx_);
  double dDd = 0.0;
  if (damp)
    for (int i = 0; i < n_red_; ++i) dDd += dx_[i] * dx_[i] * d_red_[i];
  for (int l = 0; l < num_lm_; ++l) {
    const int e = lm_dim_[l];
    const int c0 = lm_cpl_begin_[l];
    const int c1 = lm_cpl_begin_[l + 1];
    if (std::isinf(dl_[l][0])) {
      for (int p = 0; p < e; ++p) dl_[l][p] = 0.0;
      continue;
    }
    double t[3];
    for (int p = 0; p < e; ++p) t[p] = gl_[l][p];
    if (e == 1) {
      // 1-dof landmark: dot products over its merged contiguous segments.
      for (int a = lm_seg_begin_[l]; a < lm_seg_begin_[l + 1]; ++a)
        t[0] += Eigen::Map<const Eigen::VectorXd>(v_ + seg_v_[a], seg_len_[a])
                    .dot(dx_.segment(seg_row_[a], seg_len_[a]));
    } else {
      for (int a = c0; a < c1; ++a) {
        const int oa = cpl_row_[a];
        const int da = cpl_dim_[a];
        const double* va = v_ + cpl_v_[a];
        for (int i = 0; i < da; ++i)
          for (int p = 0; p < e; ++p) t[p] += va[i * e + p] * dx_[oa + i];
      }
    }
    if (e == 1) {
      dl_[l][0] = -dl_[l][0] * t[0];
    } else {
      for (int p = 0; p < e; ++p) {
        double s = 0.0;
        for (int q = 0; q < e; ++q) s += winv_[l][p * e + q] * t[q];
        dl_[l][p] = -s;
      }
    }
    for (int p = 0; p < e; ++p) {
      gdx += gl_[l][p] * dl_[l][p];
      if (damp) {
        const double s2 = scale_l_[l][p] * scale_l_[l][p];
        dDd += dl_[l][p] * dl_[l][p] * lm_scale *
               std::clamp(Hll_[l][p * e + p] * s2, min_diag_, max_diag_) / s2;
      }
    }
    if (!std::isfinite(dl_[l][0])) return false;
  }
  *model_cost_change = -0.5 * gdx + 0.5 * dDd;
  return std::isfinite(*model_cost_change);
}

// S = [A B; B^T C] with A the landmark-coupled front rows and C the tail. When C is sparse (the
// IMU chain makes it block-tridiagonal) it is eliminated first: C = U^T U by an envelope Cholesky,
// X = U^-T B^T, A' = A - X^T X (dense rank update), A' factored by Eigen's LLT. The dense
// factorization then runs on the front rows only (72 instead of 171 in the VIO window). Everything
// is in place in S's upper triangle: U over C, X^T over B.
bool Problem::factor_and_solve() {
  MatrixMap S = S_.m();
  if (!split_) {
    Eigen::Ref<Eigen::MatrixXd> S_ref(S);
    Eigen::LLT<Eigen::Ref<Eigen::MatrixXd>, Eigen::Upper> llt(S_ref);
    if (llt.info() != Eigen::Success) return false;
    dx_ = -rhs_;
    llt.solveInPlace(dx_);
    return dx_.allFinite();
  }
  const int nf = n_front_;
  const int n = n_red_;
  const Eigen::Index ld = S.outerStride();
  double* s = S.data();
  auto col = [s, ld](int j) { return s + j * ld; };
  // Envelope Cholesky of C (up-looking, column by column): U(i,j) for env_first_[j] <= i <= j.
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
    // X^T column j (rows 0..nf): (B^T(j,:) - sum_k U(k,j) X(k,:)) / U(j,j).
    for (int k = fj; k < j; ++k) {
      const double u = cj[k];
      const double* xk = col(k);
      for (int r = 0; r < nf; ++r) cj[r] -= u * xk[r];
    }
    const double inv = 1.0 / cj[j];
    for (int r = 0; r < nf; ++r) cj[r] *= inv;
  }
  // A' = A - X^T X, then the dense LLT of the front rows.
  S.topLeftCorner(nf, nf).selfadjointView<Eigen::Upper>().rankUpdate(S.block(0, nf, nf, n - nf),
                                                                      -1.0);
  Eigen::Ref<Eigen::MatrixXd> A_ref(S.topLeftCorner(nf, nf));
  Eigen::LLT<Eigen::Ref<Eigen::MatrixXd>, Eigen::Upper> llt(A_ref);
  if (llt.info() != Eigen::Success) return false;
  // y = U^-T rc (kept in dx_ tail), xa = -A'^-1 (ra - X^T y), xc = -U^-1 (y + X xa).
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
    for (int r = 0; r < nf; ++r) x[r] += cj[r] * y;
  }
  auto xa = dx_.head(nf);
  llt.solveInPlace(xa);
  for (int j = nf; j < n; ++j) {
    const double* cj = col(j);
    double d = x[j];
    for (int r = 0; r < nf; ++r) d += cj[r] * x[r];
    x[j] = -d;
  }
  for (int j = n - 1; j >= nf; --j) {
    const double* cj = col(j);
    x[j] /= cj[j];
    const double xj = x[j];
    for (int k = env_first_[j]; k < j; ++k) x[k] -= cj[k] * xj;
  }
  return dx_.allFinite();
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

SolverStatus Problem::solve(const SolverOptions& options, SolverSummary* summary) {
  const auto t0 = std::chrono::steady_clock::now();
  SolverSummary sum;
  auto finish = [&](SolverStatus s, Termination t, double cost) {
    sum.termination = t;
    sum.final_cost = cost;
    sum.solve_time_s = seconds_since(t0);
    if (summary != nullptr) *summary = sum;
    return s;
  };
  if (!options.validate()) return finish(SolverStatus::kInvalidInput, Termination::kFailure, 0.0);
  const SolverStatus st = prepare();
  if (st != SolverStatus::kOk) return finish(st, Termination::kFailure, 0.0);
  min_diag_ = options.min_lm_diagonal;
  max_diag_ = options.max_lm_diagonal;
  const bool lm = options.method == Method::kLevenbergMarquardt;

  for (int i = 0; i < num_blocks_; ++i)
    if (!all_finite(blocks_[i].x, blocks_[i].ambient))
      return finish(SolverStatus::kInvalidInput, Termination::kFailure, 0.0);
  const double fixed = fixed_cost();
  if (!std::isfinite(fixed)) return finish(SolverStatus::kInvalidInput, Termination::kFailure, 0.0);

  // Iteration 0.
  double x_cost = 0.0;
  if (!linearize(true, &x_cost))
    return finish(SolverStatus::kInvalidInput, Termination::kFailure, 0.0);
  ++sum.linearizations;
  sum.initial_cost = x_cost + fixed;
  for (int i = 0; i < n_red_; ++i)
    scale_red_[i] = options.jacobi_scaling ? 1.0 / (1.0 + std::sqrt(H_.m()(i, i))) : 1.0;
  for (int l = 0; l < num_lm_; ++l)
    for (int p = 0; p < lm_dim_[l]; ++p)
      scale_l_[l][p] =
          options.jacobi_scaling ? 1.0 / (1.0 + std::sqrt(Hll_[l][p * lm_dim_[l] + p])) : 1.0;
  double grad_norm = gradient_max_norm();

  double radius = options.initial_trust_region_radius;
  double decrease_factor = 2.0;
  double x_norm = -1.0;  // as Ceres: unknown until the first accepted step
  bool step_successful = true;
  int invalid_steps = 0;
  int iteration = 0;
  double ambient_tmp[capacity::kMaxBlockAmbientSize];
  double delta_tmp[capacity::kMaxBlockTangentSize];

  while (true) {
    // Termination tests in Ceres' order (FinalizeIterationAndCheckIfMinimizerCanContinue).
    if (seconds_since(t0) >= options.max_time_s)
      return finish(SolverStatus::kTimeBudget, Termination::kTimeBudget, x_cost + fixed);
    if (iteration >= options.max_iterations)
      return finish(SolverStatus::kMaxIterations, Termination::kMaxIterations, x_cost + fixed);
    if (step_successful && grad_norm <= options.gradient_tolerance)
      return finish(SolverStatus::kConverged, Termination::kGradientTolerance, x_cost + fixed);
    if (lm && radius <= options.min_trust_region_radius)
      return finish(SolverStatus::kConverged, Termination::kMinTrustRegionRadius, x_cost + fixed);

    ++iteration;
    sum.iterations = iteration;
    step_successful = false;
    double mcc = 0.0;
    const bool valid = compute_step(lm ? 1.0 / radius : 0.0, &mcc) &&
                       (mcc > 0.0 || !lm);
    if (!valid) {
      if (++invalid_steps >= options.max_consecutive_invalid_steps || !lm)
        return finish(SolverStatus::kNumericalFailure, Termination::kFailure, x_cost + fixed);
      radius /= decrease_factor;
      decrease_factor *= 2.0;
      continue;
    }
    invalid_steps = 0;

    // Candidate x + delta written in place (old values backed up).
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
    double cand_cost = 0.0;
    if (!linearize(false, &cand_cost)) cand_cost = std::numeric_limits<double>::max();
    auto restore = [&]() {
      for (int i = 0; i < num_blocks_; ++i) {
        const Block& b = blocks_[i];
        if (b.constant) continue;
        for (int j = 0; j < b.ambient; ++j) b.x[j] = backup_[i][j];
      }
    };

    const double step_norm = std::sqrt(step_sq);
    if (step_norm <= options.parameter_tolerance * (x_norm + options.parameter_tolerance)) {
      restore();
      sum.iterations = iteration - 1;  // as Ceres: the attempt that ends the solve is not listed
      return finish(SolverStatus::kConverged, Termination::kParameterTolerance, x_cost + fixed);
    }
    if (std::abs(x_cost - cand_cost) <= options.function_tolerance * x_cost) {
      restore();
      sum.iterations = iteration - 1;
      return finish(SolverStatus::kConverged, Termination::kFunctionTolerance, x_cost + fixed);
    }
    const double relative_decrease = (x_cost - cand_cost) / mcc;
    const bool accept = lm ? relative_decrease > options.min_relative_decrease
                           : cand_cost < std::numeric_limits<double>::max();
    if (accept) {
      x_cost = cand_cost;
      // The last permitted step: the loop's next tests end the solve before any of them reads
      // the Jacobians, so linearizing here would only be thrown away (the time test still comes
      // first, as in the loop). A window solve capped at 3 iterations saves 1 of its 7 passes.
      if (iteration >= options.max_iterations) {
        ++sum.successful_steps;
        if (seconds_since(t0) >= options.max_time_s)
          return finish(SolverStatus::kTimeBudget, Termination::kTimeBudget, x_cost + fixed);
        return finish(SolverStatus::kMaxIterations, Termination::kMaxIterations, x_cost + fixed);
      }
      x_norm = variable_x_norm();
      if (!linearize(true, &x_cost)) {
        restore();
        return finish(SolverStatus::kNumericalFailure, Termination::kFailure, x_cost + fixed);
      }
      ++sum.linearizations;
      grad_norm = gradient_max_norm();
      step_successful = true;
      ++sum.successful_steps;
      const double q = 2.0 * relative_decrease - 1.0;
      radius = std::min(options.max_trust_region_radius,
                        radius / std::max(1.0 / 3.0, 1.0 - q * q * q));
      decrease_factor = 2.0;
    } else {
      restore();
      radius /= decrease_factor;
      decrease_factor *= 2.0;
    }
  }
}

SolverStatus Problem::marginalize(const BlockId* ids, int n, MarginalPrior* out) {
  if (out == nullptr || n < 0) return SolverStatus::kInvalidInput;
  const SolverStatus st = prepare();
  if (st != SolverStatus::kOk) return st;
  for (int i = 0; i < num_blocks_; ++i) {
    marg_[i] = false;
    touched_[i] = false;
  }
  for (int k = 0; k < n; ++k) {
    if (ids[k] < 0 || ids[k] >= num_blocks_) return SolverStatus::kInvalidInput;
    marg_[ids[k]] = !blocks_[ids[k]].constant;
  }
  auto touches_marg = [&](const Residual& rb) {
    for (int j = 0; j < rb.num_blocks; ++j)
      if (marg_[rb.blocks[j]]) return true;
    return false;
  };
  // Landmarks of marginalized residuals must be marginalized too (their information would
  // otherwise be counted twice: in the prior and in their remaining residuals).
  for (int k = 0; k < num_residuals_; ++k) {
    const Residual& rb = residuals_[k];
    if (rb.fixed || !touches_marg(rb)) continue;
    for (int j = 0; j < rb.num_blocks; ++j) {
      const Block& b = blocks_[rb.blocks[j]];
      if (b.eliminate && !b.constant && !marg_[rb.blocks[j]]) return SolverStatus::kInvalidInput;
    }
  }

  if (callback_ != nullptr) callback_->prepare_for_evaluation();
  H_.m().setZero();
  b_.setZero();
  double r[capacity::kMaxResidualSize];
  double c = 0.0;
  for (int q = 0; q < num_free_res_; ++q) {
    const Residual& rb = residuals_[free_res_[q]];
    if (!touches_marg(rb)) continue;
    if (!evaluate_residual(rb, true, r, &c)) return SolverStatus::kInvalidInput;
    accumulate_residual(free_res_[q], r);
  }
  for (int l = 0; l < num_lm_; ++l) {
    if (!marg_[lm_block_[l]]) continue;
    for (int i = 0; i < 9; ++i) Hll_[l][i] = 0.0;
    for (int i = 0; i < 3; ++i) gl_[l][i] = 0.0;
    for (int a = lm_cpl_begin_[l]; a < lm_cpl_begin_[l + 1]; ++a)
      std::fill(v_ + cpl_v_[a], v_ + cpl_v_[a] + cpl_dim_[a] * lm_dim_[l], 0.0);
    for (int q = lm_res_begin_[l]; q < lm_res_begin_[l + 1]; ++q) {
      if (!evaluate_residual(residuals_[lm_res_[q]], true, r, &c)) return SolverStatus::kInvalidInput;
      accumulate_residual(lm_res_[q], r);
    }
    eliminate_landmark(l, 0.0, H_.m(), b_, false);
  }
  for (int p = 0; p < num_priors_; ++p) {
    const PriorRef& pr = priors_[p];
    if (pr.fixed) continue;
    bool hit = false;
    for (int i = 0; i < pr.prior->num_blocks(); ++i) hit = hit || marg_[pr.blocks[i]];
    if (hit && !linearize_prior(pr, true, &c)) return SolverStatus::kInvalidInput;
  }

  // Partition the reduced rows into marginalized (m) and kept (k) blocks.
  int m_rows[capacity::kMaxMarginalizedDim];
  int k_rows[capacity::kMaxReducedDim];
  int dm = 0, dk = 0, nk = 0;
  for (int i = 0; i < num_blocks_; ++i) {
    const Block& b = blocks_[i];
    if (b.constant || b.eliminate) continue;
    if (marg_[i]) {
      if (dm + b.tangent > capacity::kMaxMarginalizedDim) return SolverStatus::kFull;
      for (int j = 0; j < b.tangent; ++j) m_rows[dm++] = b.index + j;
    } else if (touched_[i]) {
      PriorBlock& pb = prior_blocks_[nk++];
      pb.source_id = i;
      pb.manifold = b.manifold;
      pb.ambient_size = b.ambient;
      pb.tangent_size = b.tangent;
      pb.offset = dk;
      for (int j = 0; j < b.ambient; ++j) pb.x_lin[j] = b.x[j];
      for (int j = 0; j < b.tangent; ++j) k_rows[dk++] = b.index + j;
    }
  }
  auto sym = [this](int i, int j) { return i <= j ? H_.m()(i, j) : H_.m()(j, i); };
  Hmm_.resize(dm, dm);
  Hkm_.resize(dk, dm);
  S_.resize(dk, dk);
  rhs_.resize(dk);
  dx_.resize(dm);
  for (int a = 0; a < dm; ++a) {
    dx_[a] = b_[m_rows[a]];
    for (int bb = 0; bb < dm; ++bb) Hmm_(a, bb) = sym(m_rows[a], m_rows[bb]);
    for (int k = 0; k < dk; ++k) Hkm_(k, a) = sym(k_rows[k], m_rows[a]);
  }
  for (int k = 0; k < dk; ++k) {
    rhs_[k] = b_[k_rows[k]];
    for (int j = 0; j < dk; ++j) S_.m()(k, j) = sym(k_rows[k], k_rows[j]);
  }
  if (dm > 0) {
    // Pseudo-inverse by eigen-decomposition of the small (<= 48) marginalized block: a
    // direction without information is dropped instead of blowing up.
    eig_.compute(Hmm_);
    if (eig_.info() != Eigen::Success) return SolverStatus::kSingular;
    const auto& ev = eig_.eigenvalues();
    const double ev_max = ev.maxCoeff();
    if (!(ev_max > 0.0)) return SolverStatus::kSingular;
    Hmm_inv_.resize(dm, dm);
    Hmm_inv_.setZero();
    for (int a = 0; a < dm; ++a) {
      if (ev[a] > ev_max * 1e-12)
        Hmm_inv_.noalias() +=
            (1.0 / ev[a]) * eig_.eigenvectors().col(a) * eig_.eigenvectors().col(a).transpose();
    }
    T_.resize(dk, dm);
    T_.noalias() = Hkm_.lazyProduct(Hmm_inv_);
    S_.m().noalias() -= T_.lazyProduct(Hkm_.transpose());
    rhs_.noalias() -= T_.lazyProduct(dx_);
  }
  const SolverStatus ps = out->set_from_information(prior_blocks_, nk, S_.m(), rhs_);
  // The workspace sizes belong to the solve layout again.
  prepared_ = false;
  return ps;
}

}  // namespace ums::solver
