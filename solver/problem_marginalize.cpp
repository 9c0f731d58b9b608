// Problem::marginalize() (docs/solver.md, "Marginalization"): the residuals and priors touching
// the listed blocks linearized at the current values, their landmarks Schur-eliminated, the listed
// reduced blocks removed by a pseudo-inverse, the marginal over the kept blocks made a prior.
#include "solver/problem.hpp"

#include <algorithm>

namespace ums::solver {

// The reduced rows of the marginalized (m) and of the kept, touched (k) blocks.
struct Problem::MarginalRows {
  int m_rows[capacity::kMaxMarginalizedDim];
  int k_rows[capacity::kMaxReducedDim];
  int dm = 0;  // marginalized dimension
  int dk = 0;  // kept dimension
  int nk = 0;  // kept blocks (prior_blocks_[0..nk))
};

SolverStatus Problem::marginalize(const BlockId* ids, int n, MarginalPrior* out) {
  if (out == nullptr || n < 0) return SolverStatus::kInvalidInput;
  const SolverStatus st = prepare();
  if (st != SolverStatus::kOk) return st;
  const SolverStatus ms = marginalize_prepared(ids, n, out);
  // The workspace was resized for the marginal system: it belongs to the solve layout again,
  // whichever step stopped (a kFull or kSingular used to leave the problem marked prepared).
  prepared_ = false;
  return ms;
}

SolverStatus Problem::marginalize_prepared(const BlockId* ids, int n, MarginalPrior* out) {
  SolverStatus st = select_marginalized(ids, n);
  if (st != SolverStatus::kOk) return st;
  st = linearize_marginalized();
  if (st != SolverStatus::kOk) return st;
  MarginalRows rows;
  st = partition_marginal_rows(&rows);
  if (st != SolverStatus::kOk) return st;
  gather_marginal_system(rows);
  if (rows.dm > 0) {
    st = schur_marginalized(rows.dm, rows.dk);
    if (st != SolverStatus::kOk) return st;
  }
  return out->set_from_information(prior_blocks_, rows.nk, S_.m(), rhs_);
}

bool Problem::touches_marginalized(const Residual& rb) const {
  for (int j = 0; j < rb.num_blocks; ++j)
    if (marg_[rb.blocks[j]]) return true;
  return false;
}

// marg_[block] for the listed variable blocks (touched_ cleared for the linearization).
SolverStatus Problem::select_marginalized(const BlockId* ids, int n) {
  for (int i = 0; i < num_blocks_; ++i) {
    marg_[i] = false;
    touched_[i] = false;
  }
  for (int k = 0; k < n; ++k) {
    if (ids[k] < 0 || ids[k] >= num_blocks_) return SolverStatus::kInvalidInput;
    marg_[ids[k]] = !blocks_[ids[k]].constant;
  }
  // Landmarks of marginalized residuals must be marginalized too (their information would
  // otherwise be counted twice: in the prior and in their remaining residuals).
  for (int k = 0; k < num_residuals_; ++k) {
    const Residual& rb = residuals_[k];
    if (rb.fixed || !touches_marginalized(rb)) continue;
    for (int j = 0; j < rb.num_blocks; ++j) {
      const Block& b = blocks_[rb.blocks[j]];
      if (b.eliminate && !b.constant && !marg_[rb.blocks[j]]) return SolverStatus::kInvalidInput;
    }
  }
  return SolverStatus::kOk;
}

// H_, b_ from the residuals and priors touching marginalized blocks, landmarks eliminated.
SolverStatus Problem::linearize_marginalized() {
  if (callback_ != nullptr) callback_->prepare_for_evaluation();
  zero_upper(H_.m());
  b_.setZero();
  mark_touched_ = true;
  const SolverStatus st = accumulate_marginalized();
  mark_touched_ = false;
  return st;
}

SolverStatus Problem::accumulate_marginalized() {
  double r[capacity::kMaxResidualSize];
  double c = 0.0;
  for (int q = 0; q < num_free_res_; ++q) {
    const Residual& rb = residuals_[free_res_[q]];
    if (!touches_marginalized(rb)) continue;
    if (!evaluate_residual(rb, true, r, &c)) return SolverStatus::kInvalidInput;
    accumulate_residual(free_res_[q], r);
  }
  for (int l = 0; l < num_lm_; ++l) {
    if (!marg_[lm_block_[l]]) continue;
    if (!linearize_marginalized_landmark(l)) return SolverStatus::kInvalidInput;
  }
  for (int p = 0; p < num_priors_; ++p) {
    const PriorRef& pr = priors_[p];
    if (pr.fixed) continue;
    bool hit = false;
    for (int i = 0; i < pr.prior->num_blocks(); ++i) hit = hit || marg_[pr.blocks[i]];
    if (hit && !linearize_prior(pr, true, &c)) return SolverStatus::kInvalidInput;
  }
  return SolverStatus::kOk;
}

// Landmark l's residuals accumulated, then l Schur-eliminated into H_, b_ (no damping).
bool Problem::linearize_marginalized_landmark(int l) {
  double r[capacity::kMaxResidualSize];
  double c = 0.0;
  for (int i = 0; i < 9; ++i) Hll_[l][i] = 0.0;
  for (int i = 0; i < 3; ++i) gl_[l][i] = 0.0;
  for (int a = lm_cpl_begin_[l]; a < lm_cpl_begin_[l + 1]; ++a)
    std::fill(v_ + cpl_v_[a], v_ + cpl_v_[a] + cpl_dim_[a] * lm_dim_[l], 0.0);
  const bool lifted = lm_lift_[l] >= 0;
  if (lifted) begin_lift(l);
  for (int q = lm_res_begin_[l]; q < lm_res_begin_[l + 1]; ++q) {
    if (!evaluate_residual(residuals_[lm_res_[q]], true, r, &c)) return false;
    accumulate_residual(lm_res_[q], r);
  }
  if (lifted && !finish_lift(l)) return false;
  eliminate_landmark(l, 0.0, H_.m(), b_, false);
  return true;
}

// Partition the reduced rows into marginalized (m) and kept (k) blocks; the kept blocks' values
// become the prior's linearization points.
SolverStatus Problem::partition_marginal_rows(MarginalRows* rows) {
  int& dm = rows->dm;
  int& dk = rows->dk;
  int& nk = rows->nk;
  for (int i = 0; i < num_blocks_; ++i) {
    const Block& b = blocks_[i];
    if (b.constant || b.eliminate) continue;
    if (marg_[i]) {
      if (dm + b.tangent > capacity::kMaxMarginalizedDim) return SolverStatus::kFull;
      for (int j = 0; j < b.tangent; ++j) rows->m_rows[dm++] = b.index + j;
    } else if (touched_[i]) {
      PriorBlock& pb = prior_blocks_[nk++];
      pb.source_id = i;
      pb.manifold = b.manifold;
      pb.ambient_size = b.ambient;
      pb.tangent_size = b.tangent;
      pb.offset = dk;
      for (int j = 0; j < b.ambient; ++j) pb.x_lin[j] = b.x[j];
      for (int j = 0; j < b.tangent; ++j) rows->k_rows[dk++] = b.index + j;
    }
  }
  return SolverStatus::kOk;
}

// Hmm_, Hkm_, dx_ = b_m (marginalized) and S_ = H_kk, rhs_ = b_k (kept) from the upper triangle.
void Problem::gather_marginal_system(const MarginalRows& rows) {
  const int dm = rows.dm;
  const int dk = rows.dk;
  const int* m_rows = rows.m_rows;
  const int* k_rows = rows.k_rows;
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
}

// S_ -= H_km H_mm^+ H_mk, rhs_ -= H_km H_mm^+ b_m. Pseudo-inverse by eigen-decomposition of the
// small (<= 48) marginalized block: a direction without information is dropped instead of
// blowing up.
SolverStatus Problem::schur_marginalized(int dm, int dk) {
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
  return SolverStatus::kOk;
}

}  // namespace ums::solver
