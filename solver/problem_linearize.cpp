// Linearization (docs/solver.md, "Linearization"): residuals evaluated with their robust loss,
// accumulated into the reduced H (upper triangle) and b = J^T r, per landmark H_ll, g_l and the
// couplings V; the marginalization prior's H and g; the cost passes (candidate, fixed cost).
#include "solver/problem.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

#include "solver/double_pair.hpp"
#include "solver/finite.hpp"

namespace ums::solver {
namespace {

inline void add_jtr(DenseVector& b, int o, const double* J, int t, const double* r, int rows) {
  if (rows == 2 && t == 6) {
    const Eigen::Map<const Eigen::Matrix<double, 2, 6, Eigen::RowMajor>> A(J);
    b.segment<6>(o).noalias() += A.transpose() * Eigen::Map<const Eigen::Vector2d>(r);
    return;
  }
  add_jtj_any(b.data() + o, 0, J, t, r, 1, rows);
}

}  // namespace

bool Problem::evaluate_residual(const Residual& rb, bool jacobians, double* r, double* cost, double* keep) {
  // A cost pass hands every residual the same views with nothing wanted (no_jac_, never written).
  const JacobianView* jv = no_jac_;
  if (jacobians) {
    for (int j = 0; j < rb.num_blocks; ++j) {
      jac_wanted_[j] = rb.variable[j];
      jac_view_[j].data = rb.variable[j] ? jac_ws_[j] : nullptr;
      jac_view_[j].row_stride = rb.tangent[j];
      jac_view_[j].point = false;
    }
    if (rb.lift_pos >= 0) {
      // d r / d point in the host's place; the landmark's column comes from the lift.
      jac_view_[rb.lift_pos].row_stride = 3;
      jac_view_[rb.lift_pos].point = true;
      jac_view_[rb.lm_pos].data = nullptr;
      jac_wanted_[rb.lm_pos] = false;
    }
    jv = jac_view_;
  }
  if (!rb.fn->evaluate(rb.params, r, jv)) return false;
  const int rows = rb.rows;
  if (keep != nullptr) {
    if (rows == 2) {  // the reprojections: two stores, not a memmove call
      keep[0] = r[0];
      keep[1] = r[1];
    } else {
      std::copy(r, r + rows, keep);
    }
  }
  // Two rows (the reprojections): the loop's sum, (0 + r0^2) + r1^2, without the loop.
  double sq = rows == 2 ? r[0] * r[0] + r[1] * r[1] : 0.0;
  if (rows != 2)
    for (int i = 0; i < rows; ++i) sq += r[i] * r[i];
  if (!std::isfinite(sq)) return false;
  // Non-finite Jacobians are caught once per linearization (NaN/Inf propagate into H, b, V).
  // The trivial loss, and Huber's quadratic region where nearly every residual lies: rho(s) = s,
  // rho' = 1, rho'' = 0, no correction (what RobustLoss::evaluate gives, without the call).
  if (rb.loss.type == LossType::kTrivial || (rb.loss.type == LossType::kHuber && !(sq > rb.loss.scale * rb.loss.scale))) {
    *cost = 0.5 * sq;
    return true;
  }
  double rho[3];
  rb.loss.evaluate(sq, rho);
  *cost = 0.5 * rho[0];
  // Inside Huber's quadratic region (and whenever rho' = 1, rho'' = 0) the correction is the
  // identity: skip the multiplications by 1 (bit-identical result).
  if (jacobians && !(rho[1] == 1.0 && rho[2] == 0.0)) {
    const LossCorrector corrector(sq, rho);
    for (int j = 0; j < rb.num_blocks; ++j) {
      if (!jac_wanted_[j]) continue;
      const int t = jac_view_[j].row_stride;  // the block's tangent, or 3 for a point Jacobian
      corrector.correct_jacobian(rows, t, t, r, jac_ws_[j]);
    }
    corrector.correct_residual(rows, r);
  }
  return std::isfinite(*cost);
}

// b_a += J_a^T r and H(a, a..) += J_a^T J_c for the residual's sorted block a and the blocks after
// it (2 rows, 6-dof blocks; the block at position `skip` of the residual, if any, left out: the
// lifted host). Diagonal block: the upper triangle only.
void Problem::add_blocks_2x6(const Residual& rb, int a, const double* r, int skip) {
  MatrixMap H = acc_H_->m();
  const Eigen::Index ld = H.outerStride();
  const int ka = rb.sorted[a];
  const double* Ja = jac_ws_[ka];
  const int oa = blocks_[rb.blocks[ka]].index;
  Pair j0[3], j1[3];
  for (int i = 0; i < 3; ++i) {
    j0[i] = load_pair(Ja + 2 * i);
    j1[i] = load_pair(Ja + 6 + 2 * i);
  }
  col_update2<6>(acc_b_->data() + oa, j0, j1, r[0], r[1]);
  add_jtj_2x6<true>(H.data() + oa * ld + oa, ld, Ja, Ja);
  for (int c = a + 1; c < rb.num_sorted; ++c) {
    const int kc = rb.sorted[c];
    if (kc == skip) continue;
    add_jtj_2x6<false>(H.data() + blocks_[rb.blocks[kc]].index * ld + oa, ld, Ja, jac_ws_[kc]);
  }
}

// The dominant case (a 2-row reprojection over 6-dof blocks and one inverse depth), with every
// block product fixed-size and the blocks pre-sorted by row so each lands in the upper triangle.
void Problem::accumulate_two_row(const Residual& rb, const double* r) {
  const double* Jl = rb.lm_pos >= 0 ? jac_ws_[rb.lm_pos] : nullptr;
  for (int a = 0; a < rb.num_sorted; ++a) {
    add_blocks_2x6(rb, a, r, -1);
    if (Jl != nullptr) {
      const int ka = rb.sorted[a];
      Eigen::Map<Eigen::Matrix<double, 6, 1>>(v_ + cpl_v_[rb.slot[ka]]).noalias() +=
          Eigen::Map<const Eigen::Matrix<double, 2, 6, Eigen::RowMajor>>(jac_ws_[ka]).transpose() *
          Eigen::Map<const Eigen::Vector2d>(Jl);
    }
  }
  if (Jl != nullptr) {
    const int l = rb.landmark;
    Hll_[l][0] += Jl[0] * Jl[0] + Jl[1] * Jl[1];
    gl_[l][0] += Jl[0] * r[0] + Jl[1] * r[1];
  }
}

// J^T J, J^T r of one residual into H, b and its landmark's H_ll, g_l, V (touched_ marks blocks).
void Problem::accumulate_residual(int res_index, const double* r) {
  const Residual& rb = residuals_[res_index];
  if (gradient_pass_) {
    accumulate_gradient(rb, r);
    return;
  }
  const int rows = rb.rows;
  if (rb.lift_pos >= 0) {
    accumulate_lifted(rb, r);
    return;
  }
  if (rows == 2 && rb.fast2) {
    // marginalize() keeps exactly the touched blocks: the fast path must mark them too.
    if (mark_touched_)
      for (int a = 0; a < rb.num_blocks; ++a)
        if (jac_wanted_[a]) touched_[rb.blocks[a]] = true;
    accumulate_two_row(rb, r);
    return;
  }
  const int lm_j = accumulate_reduced(rb, r);
  if (lm_j < 0) return;
  const int l = blocks_[rb.blocks[lm_j]].index;
  if (lm_dim_[l] == 1)
    accumulate_landmark1(rb, l, jac_ws_[lm_j], r);
  else
    accumulate_landmark(rb, l, jac_ws_[lm_j], r);
}

void Problem::accumulate_gradient(const Residual& rb, const double* r) {
  const int rows = rb.rows;
  if (rows == 2 && rb.fast2) {  // the reprojections: 2 x 6 pose blocks, a point or a 1-dof landmark
    for (int a = 0; a < rb.num_sorted; ++a) {
      const int ka = rb.sorted[a];
      if (ka == rb.lift_pos) continue;
      const double* J = jac_ws_[ka];
      Pair j0[3], j1[3];
      for (int i = 0; i < 3; ++i) {
        j0[i] = load_pair(J + 2 * i);
        j1[i] = load_pair(J + 6 + 2 * i);
      }
      col_update2<6>(acc_b_->data() + blocks_[rb.blocks[ka]].index, j0, j1, r[0], r[1]);
    }
    if (rb.lift_pos >= 0) {
      const double* A = jac_ws_[rb.lift_pos];
      for (int k = 0; k < 3; ++k) lift_s_[k] += A[k] * r[0] + A[3 + k] * r[1];
      lift_host_slot_ = rb.slot[rb.lift_pos];
    } else if (rb.lm_pos >= 0 && jac_wanted_[rb.lm_pos]) {
      const double* Jl = jac_ws_[rb.lm_pos];
      gl_[rb.landmark][0] += Jl[0] * r[0] + Jl[1] * r[1];
    }
    return;
  }
  // Lifted residuals are all fast2 (assign_lifts): none reaches this general path.
  for (int a = 0; a < rb.num_blocks; ++a) {
    const double* J = jac_ws_[a];
    if (!jac_wanted_[a]) continue;
    const Block& ba = blocks_[rb.blocks[a]];
    if (!ba.eliminate) {
      add_jtr(*acc_b_, ba.index, J, ba.tangent, r, rows);
      continue;
    }
    const int l = ba.index, e = lm_dim_[l];
    for (int p = 0; p < e; ++p) {
      double g = 0.0;
      for (int i = 0; i < rows; ++i) g += J[i * e + p] * r[i];
      gl_[l][p] += g;
    }
  }
}

// General path, reduced blocks: b += J_a^T r, H(a, c) += J_a^T J_c (upper triangle). Returns the
// position of the variable eliminated block, or -1.
int Problem::accumulate_reduced(const Residual& rb, const double* r) {
  const int rows = rb.rows;
  int lm_j = -1;
  // Each block's non-zero rows (the IMU factor's pose blocks have none in the bias rows): a block
  // pair's products are summed over the rows both have, the diagonal blocks over their upper
  // triangle; the same doubles as the whole products (double_pair.hpp, add_jtj_rows).
  int lo[capacity::kMaxBlocksPerResidual], hi[capacity::kMaxBlocksPerResidual];
  for (int a = 0; a < rb.num_blocks; ++a)
    if (jac_wanted_[a]) nonzero_rows(jac_ws_[a], rows, blocks_[rb.blocks[a]].tangent, &lo[a], &hi[a]);
  MatrixMap H = acc_H_->m();
  for (int a = 0; a < rb.num_blocks; ++a) {
    if (!jac_wanted_[a]) continue;
    const Block& ba = blocks_[rb.blocks[a]];
    if (mark_touched_) touched_[rb.blocks[a]] = true;
    if (ba.eliminate) {
      lm_j = a;
      continue;
    }
    add_jtr(*acc_b_, ba.index, jac_ws_[a], ba.tangent, r, rows);
    for (int c = a; c < rb.num_blocks; ++c) {
      if (!jac_wanted_[c]) continue;
      const Block& bc = blocks_[rb.blocks[c]];
      if (bc.eliminate) continue;
      const int r0 = std::max(lo[a], lo[c]), r1 = std::min(hi[a], hi[c]);
      const bool upper = c == a;
      if (ba.index <= bc.index)
        add_jtj_rows(H.data() + bc.index * H.outerStride() + ba.index, H.outerStride(), jac_ws_[a], ba.tangent,
                     jac_ws_[c], bc.tangent, r0, r1, upper);
      else
        add_jtj_rows(H.data() + ba.index * H.outerStride() + bc.index, H.outerStride(), jac_ws_[c], bc.tangent,
                     jac_ws_[a], ba.tangent, r0, r1, upper);
    }
  }
  return lm_j;
}

// General path, 1-dof landmark l with Jacobian column Jl: H_ll, g_l and V = J_B^T J_l.
void Problem::accumulate_landmark1(const Residual& rb, int l, const double* Jl, const double* r) {
  const int rows = rb.rows;
  double h = 0.0, g = 0.0;
  for (int i = 0; i < rows; ++i) {
    h += Jl[i] * Jl[i];
    g += Jl[i] * r[i];
  }
  Hll_[l][0] += h;
  gl_[l][0] += g;
  for (int a = 0; a < rb.num_blocks; ++a) {
    if (rb.slot[a] < 0 || !jac_wanted_[a]) continue;
    const int t = blocks_[rb.blocks[a]].tangent;
    double* v = v_ + cpl_v_[rb.slot[a]];
    const double* Ja = jac_ws_[a];
    if (rows == 2 && t == 6) {
      Eigen::Map<Eigen::Matrix<double, 6, 1>>(v).noalias() +=
          Eigen::Map<const Eigen::Matrix<double, 2, 6, Eigen::RowMajor>>(Ja).transpose() *
          Eigen::Map<const Eigen::Vector2d>(Jl);
      continue;
    }
    for (int i = 0; i < rows; ++i)
      for (int c = 0; c < t; ++c) v[c] += Ja[i * t + c] * Jl[i];
  }
}

// General path, landmark l of e = 2 or 3 dofs (Jl: rows x e row-major): H_ll, g_l, V.
void Problem::accumulate_landmark(const Residual& rb, int l, const double* Jl, const double* r) {
  const int rows = rb.rows;
  const int e = lm_dim_[l];
  for (int p = 0; p < e; ++p) {
    for (int q = 0; q < e; ++q) {
      double h = 0.0;
      for (int i = 0; i < rows; ++i) h += Jl[i * e + p] * Jl[i * e + q];
      Hll_[l][p * e + q] += h;
    }
    double g = 0.0;
    for (int i = 0; i < rows; ++i) g += Jl[i * e + p] * r[i];
    gl_[l][p] += g;
  }
  for (int a = 0; a < rb.num_blocks; ++a) {
    if (rb.slot[a] < 0 || !jac_wanted_[a]) continue;
    const int t = blocks_[rb.blocks[a]].tangent;
    double* v = v_ + cpl_v_[rb.slot[a]];  // t x e row-major
    const double* Ja = jac_ws_[a];
    for (int i = 0; i < rows; ++i)
      for (int c = 0; c < t; ++c)
        for (int q = 0; q < e; ++q) v[c * e + q] += Ja[i * t + c] * Jl[i * e + q];
  }
}

bool Problem::linearize_prior(const PriorRef& p, bool jacobians, double* cost) {
  const MarginalPrior& prior = *p.prior;
  const int dim = prior.dim();
  const double* xs[capacity::kMaxReducedBlocks];
  for (int i = 0; i < prior.num_blocks(); ++i) xs[i] = blocks_[p.blocks[i]].x;
  Eigen::Matrix3d rot[capacity::kMaxReducedBlocks];
  pe_.resize(dim);
  pr_.resize(dim);
  prior.tangent_error(xs, pe_.data(), rot);
  pr_ = prior.r0();
  pr_.noalias() += prior.sqrt_information() * pe_;
  *cost = 0.5 * pr_.squaredNorm();
  if (!std::isfinite(*cost)) return false;
  if (!jacobians) return true;
  // d r / d delta_k = J[:, k] B_k; H = B^T (J^T J) B, g = B^T J^T r, with B block-diagonal.
  pe_.noalias() = prior.sqrt_information().transpose() * pr_;
  const bool full = !gradient_pass_;
  if (full) {
    M_.resize(dim, dim);
    M_.m() = prior.information();
  }
  int k = 0;
  for (int i = 0; i < prior.num_blocks(); ++i) {
    const PriorBlock& pb = prior.block(i);
    if (pb.manifold != ManifoldType::kPose) continue;
    const int o = pb.offset + 3;
    const Eigen::Matrix3d R = rot[k++];
    pe_.segment<3>(o) = (R.transpose() * pe_.segment<3>(o)).eval();
    if (!full) continue;
    for (int c = 0; c < dim; ++c) M_.m().block<3, 1>(o, c) = (R.transpose() * M_.m().block<3, 1>(o, c)).eval();
    for (int rr = 0; rr < dim; ++rr) M_.m().block<1, 3>(rr, o) = (M_.m().block<1, 3>(rr, o) * R).eval();
  }
  for (int i = 0; i < prior.num_blocks(); ++i) {
    const Block& bi = blocks_[p.blocks[i]];
    if (bi.constant) continue;
    if (mark_touched_) touched_[p.blocks[i]] = true;
    const PriorBlock& pi = prior.block(i);
    b_.segment(bi.index, bi.tangent) += pe_.segment(pi.offset, pi.tangent_size);
    for (int j = 0; full && j < prior.num_blocks(); ++j) {
      const Block& bj = blocks_[p.blocks[j]];
      if (bj.constant || bj.index < bi.index) continue;
      const PriorBlock& pj = prior.block(j);
      H_.m().block(bi.index, bj.index, bi.tangent, bj.tangent) +=
          M_.m().block(pi.offset, pj.offset, pi.tangent_size, pj.tangent_size);
    }
  }
  return true;
}

void Problem::zero_upper(MatrixMap H) {
  for (Eigen::Index j = 0; j < H.cols(); ++j) {
    double* col = H.data() + j * H.outerStride();
    std::fill(col, col + j + 1, 0.0);
  }
}

void Problem::zero_linear_system() {
  if (gradient_pass_) {
    b_.setZero();
    if (hinted_) bsep_.head(n_front_).setZero();
    for (int l = 0; l < num_lm_; ++l)
      for (int i = 0; i < 3; ++i) gl_[l][i] = 0.0;
    return;
  }
  factor_valid_ = false;  // S_'s factor was of the matrix about to be replaced
  zero_upper(H_.m());
  b_.setZero();
  if (hinted_) {
    zero_upper(MatrixMap(Hsep_.m().data(), n_red_, n_front_));  // the rows landmarks reach
    bsep_.head(n_front_).setZero();
  }
  for (int l = 0; l < num_lm_; ++l) {
    for (int i = 0; i < 9; ++i) Hll_[l][i] = 0.0;
    for (int i = 0; i < 3; ++i) gl_[l][i] = 0.0;
  }
  std::fill(v_, v_ + v_used_, 0.0);
}

// One check of the accumulated system instead of one per Jacobian entry.
// A NaN/Inf anywhere in a Jacobian reaches the diagonal of H or H_ll (sums of squares).
bool Problem::linear_system_finite() const {
  if (!H_.m().diagonal().allFinite() || !b_.allFinite()) return false;
  for (int l = 0; l < num_lm_; ++l)
    if (!all_finite(Hll_[l], 9) || !all_finite(gl_[l], 3)) return false;
  return true;
}

bool Problem::linearize(bool jacobians, double* cost) {
  ++residual_passes_;
  if (callback_ != nullptr) callback_->prepare_for_evaluation();
  double total = 0.0;
  double r[capacity::kMaxResidualSize];
  double c = 0.0;
  const bool apart = jacobians && hinted_;
  if (jacobians) {
    sep_valid_ = false;
    zero_linear_system();
  }
  double* kept = kept_write_ >= 0 ? kept_[kept_write_] : nullptr;
  for (int q = 0; q < num_free_res_; ++q) {
    const int k = free_res_[q];
    if (!evaluate_residual(residuals_[k], jacobians, r, &c, kept_slot(kept, k))) return false;
    total += c;
    if (jacobians) accumulate_residual(k, r);
  }
  for (int l = 0; l < num_lm_; ++l) {
    if (apart && hinted_landmark(l)) {
      acc_H_ = &Hsep_;
      acc_b_ = &bsep_;
    }
    const bool ok = linearize_landmark(l, jacobians, &total, kept);
    acc_H_ = &H_;
    acc_b_ = &b_;
    if (!ok) return false;
  }
  if (apart) add_separated();
  for (int p = 0; p < num_priors_; ++p) {
    if (priors_[p].fixed) continue;
    if (!linearize_prior(priors_[p], jacobians, &c)) return false;
    total += c;
  }
  *cost = total;
  if (!std::isfinite(total)) return false;
  if (!jacobians) return true;
  if (!linear_system_finite()) return false;
  if (apart) note_separated_linearization();
  return true;
}

bool Problem::linearize_gradient(double* cost) {
  gradient_pass_ = true;
  const bool ok = linearize(true, cost);
  gradient_pass_ = false;
  return ok;
}

bool Problem::linearize_landmark(int l, bool jacobians, double* total, double* kept) {
  double r[capacity::kMaxResidualSize];
  double c = 0.0;
  const bool lifted = jacobians && lm_lift_[l] >= 0;
  if (lifted) begin_lift(l);
  for (int q = lm_res_begin_[l]; q < lm_res_begin_[l + 1]; ++q) {
    const int k = lm_res_[q];
    if (!evaluate_residual(residuals_[k], jacobians, r, &c, kept_slot(kept, k))) return false;
    *total += c;
    if (jacobians) accumulate_residual(k, r);
  }
  return !lifted || (gradient_pass_ ? finish_lift_gradient(l) : finish_lift(l));
}

// Rows [0, n_front_) are the blocks landmarks couple to: the only ones their residuals reach.
void Problem::add_separated() {
  if (gradient_pass_) {
    for (int i = 0; i < n_front_; ++i) b_[i] += bsep_[i];
    return;
  }
  MatrixMap H = H_.m();
  const MatrixMap Hs = Hsep_.m();
  for (int j = 0; j < n_front_; ++j) {
    double* col = H.data() + j * H.outerStride();
    const double* sep = Hs.data() + j * Hs.outerStride();
    for (int i = 0; i <= j; ++i) col[i] += sep[i];
  }
  for (int i = 0; i < n_front_; ++i) b_[i] += bsep_[i];
}

void Problem::note_separated_linearization() {
  for (int i = 0; i < num_blocks_; ++i) std::copy(blocks_[i].x, blocks_[i].x + blocks_[i].ambient, lin_x_[i]);
  sep_valid_ = true;
}

double Problem::fixed_cost() {
  if (callback_ != nullptr) callback_->prepare_for_evaluation();
  double total = 0.0;
  double r[capacity::kMaxResidualSize];
  double c = 0.0;
  for (int k = 0; k < num_residuals_; ++k) {
    if (!residuals_[k].fixed) continue;
    if (!evaluate_residual(residuals_[k], false, r, &c)) return std::numeric_limits<double>::quiet_NaN();
    total += c;
  }
  for (int p = 0; p < num_priors_; ++p) {
    if (!priors_[p].fixed) continue;
    if (!linearize_prior(priors_[p], false, &c)) return std::numeric_limits<double>::quiet_NaN();
    total += c;
  }
  return total;
}

SolverStatus Problem::evaluate_cost(double* cost) {
  const SolverStatus st = prepare();
  if (st != SolverStatus::kOk) return st;
  double c = 0.0;
  if (!linearize(false, &c)) return SolverStatus::kInvalidInput;
  const double f = fixed_cost();
  if (!std::isfinite(f)) return SolverStatus::kInvalidInput;
  *cost = c + f;
  return SolverStatus::kOk;
}

}  // namespace ums::solver
