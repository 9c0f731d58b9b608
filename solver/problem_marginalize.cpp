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

SolverStatus Problem::set_marginalization_hint(const BlockId* ids, int n) {
  if (n < 0 || (n > 0 && ids == nullptr)) return SolverStatus::kInvalidInput;
  for (int k = 0; k < n; ++k)
    if (ids[k] < 0 || ids[k] >= num_blocks_) return SolverStatus::kInvalidInput;
  for (int i = 0; i < num_blocks_; ++i) hint_[i] = false;
  for (int k = 0; k < n; ++k) hint_[ids[k]] = true;
  hinted_ = n > 0;
  sep_valid_ = false;
  return SolverStatus::kOk;
}

SolverStatus Problem::marginalize(const BlockId* ids, int n, MarginalPrior* out) {
  marg_reused_ = false;
  if (out == nullptr || n < 0) return SolverStatus::kInvalidInput;
  const SolverStatus st = prepare();  // a new layout drops the kept terms
  if (st != SolverStatus::kOk) return st;
  const SolverStatus ms = marginalize_prepared(ids, n, out);
  sep_valid_ = false;  // H_ and the landmark terms now hold the marginal system's
  // The workspace was resized for the marginal system: it belongs to the solve layout again,
  // whichever step stopped (a kFull or kSingular used to leave the problem marked prepared).
  prepared_ = false;
  return ms;
}

SolverStatus Problem::marginalize_prepared(const BlockId* ids, int n, MarginalPrior* out) {
  SolverStatus st = select_marginalized(ids, n);
  if (st != SolverStatus::kOk) return st;
  const bool reuse = separated_current();
  st = reuse ? reuse_marginalized() : linearize_marginalized();
  if (st != SolverStatus::kOk) return st;
  marg_reused_ = reuse;
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
  const SolverStatus st = accumulate_marginalized(false);
  mark_touched_ = false;
  return st;
}

// kept: the marginalized landmarks' terms are in H_, b_ and their own blocks already; otherwise
// each is linearized first. Then they are eliminated together (eliminate_all: each element still
// sums in landmark order).
SolverStatus Problem::accumulate_marginalized(bool kept) {
  double r[capacity::kMaxResidualSize];
  double c = 0.0;
  for (int q = 0; q < num_free_res_; ++q) {
    const Residual& rb = residuals_[free_res_[q]];
    if (!touches_marginalized(rb)) continue;
    if (!evaluate_residual(rb, true, r, &c)) return SolverStatus::kInvalidInput;
    accumulate_residual(free_res_[q], r);
  }
  if (!kept) {
    for (int l = 0; l < num_lm_; ++l)
      if (marg_[lm_block_[l]] && !linearize_marginalized_landmark(l)) return SolverStatus::kInvalidInput;
  }
  eliminate_all(0.0, H_.m(), b_, false, true);
  for (int p = 0; p < num_priors_; ++p) {
    const PriorRef& pr = priors_[p];
    if (pr.fixed) continue;
    bool hit = false;
    for (int i = 0; i < pr.prior->num_blocks(); ++i) hit = hit || marg_[pr.blocks[i]];
    if (hit && !linearize_prior(pr, true, &c)) return SolverStatus::kInvalidInput;
  }
  return SolverStatus::kOk;
}

// The last linearization's terms fit this marginalization: it kept the marginalized landmarks,
// exactly those, apart, at the blocks' present values (after a gradient pass: their gradients
// there, their matrices from the whole linearization before it).
bool Problem::separated_current() const {
  if (!sep_valid_) return false;
  for (int l = 0; l < num_lm_; ++l)
    if (marg_[lm_block_[l]] != hinted_landmark(l)) return false;
  // Only what the kept terms read must be as linearized: the blocks of the marginalized
  // landmarks' residuals and lifts (visited once each).
  bool seen[capacity::kMaxParameterBlocks] = {};
  auto same = [&](const std::int16_t* ids, int n) {
    for (int j = 0; j < n; ++j) {
      if (seen[ids[j]]) continue;
      seen[ids[j]] = true;
      if (!block_as_linearized(ids[j])) return false;
    }
    return true;
  };
  for (int l = 0; l < num_lm_; ++l) {
    if (!marg_[lm_block_[l]]) continue;
    if (lm_lift_[l] >= 0 && !same(lifts_[lm_lift_[l]].blocks, lifts_[lm_lift_[l]].num_blocks)) return false;
    for (int q = lm_res_begin_[l]; q < lm_res_begin_[l + 1]; ++q)
      if (!same(residuals_[lm_res_[q]].blocks, residuals_[lm_res_[q]].num_blocks)) return false;
  }
  return true;
}

bool Problem::block_as_linearized(int i) const {
  return std::equal(blocks_[i].x, blocks_[i].x + blocks_[i].ambient, lin_x_[i]);
}

SolverStatus Problem::note_world_moved(const BlockId* ids, int n, const Eigen::Matrix3d& R) {
  if (n < 0 || (n > 0 && ids == nullptr)) return SolverStatus::kInvalidInput;
  for (int k = 0; k < n; ++k) {
    if (ids[k] < 0 || ids[k] >= num_blocks_ || blocks_[ids[k]].manifold != ManifoldType::kPose)
      return SolverStatus::kInvalidInput;
    for (int m = 0; m < k; ++m)
      if (ids[m] == ids[k]) return SolverStatus::kInvalidInput;  // it would be turned twice
  }
  if (!sep_valid_ || !prepared_) return SolverStatus::kOk;
  if (!moved_rigidly(ids, n, R)) {
    sep_valid_ = false;
    return SolverStatus::kOk;
  }
  rotate_separated(ids, n, R);
  for (int k = 0; k < n; ++k) std::copy(blocks_[ids[k]].x, blocks_[ids[k]].x + kPoseAmbientSize, lin_x_[ids[k]]);
  return SolverStatus::kOk;
}

// Each pose's rotation is R times the linearized one, and its position R p + t with one t for all.
bool Problem::moved_rigidly(const BlockId* ids, int n, const Eigen::Matrix3d& R) const {
  constexpr double kTol = 1e-9;
  if (!(R.transpose() * R - Eigen::Matrix3d::Identity()).isZero(kTol)) return false;
  Eigen::Vector3d t = Eigen::Vector3d::Zero();
  for (int k = 0; k < n; ++k) {
    const double* now = blocks_[ids[k]].x;
    const double* lin = lin_x_[ids[k]];
    const Eigen::Vector3d p_now(now[0], now[1], now[2]), p_lin(lin[0], lin[1], lin[2]);
    const Eigen::Matrix3d R_now = Eigen::Quaterniond(now[6], now[3], now[4], now[5]).normalized().toRotationMatrix();
    const Eigen::Matrix3d R_lin = Eigen::Quaterniond(lin[6], lin[3], lin[4], lin[5]).normalized().toRotationMatrix();
    if (!(R_now - R * R_lin).isZero(kTol)) return false;
    if (k == 0) t = p_now - R * p_lin;
    if (!((p_now - (R * p_lin + t)).norm() <= kTol * (1.0 + p_now.norm()))) return false;
  }
  return true;
}

// H' = M H M^T, b' = M b, V' = M V with M = R on the moved poses' position rows, I elsewhere.
// Hsep_'s upper triangle is made whole in S_ (free between a solve and a marginalization).
void Problem::rotate_separated(const BlockId* ids, int n, const Eigen::Matrix3d& R) {
  using Rows3 = Eigen::Matrix<double, 3, Eigen::Dynamic, 0, 3, capacity::kMaxReducedDim>;
  using Cols3 = Eigen::Matrix<double, Eigen::Dynamic, 3, 0, capacity::kMaxReducedDim, 3>;
  const int f = n_front_;
  MatrixMap full = S_.m();
  MatrixMap Hs = Hsep_.m();
  for (int j = 0; j < f; ++j)
    for (int i = 0; i <= j; ++i) full(i, j) = full(j, i) = Hs(i, j);
  for (int k = 0; k < n; ++k) {
    const int o = blocks_[ids[k]].index;
    if (o < 0 || o >= f) continue;  // constant, or no landmark sees it
    const Rows3 rows = R * full.block(o, 0, 3, f);
    full.block(o, 0, 3, f) = rows;
    const Cols3 cols = full.block(0, o, f, 3) * R.transpose();
    full.block(0, o, f, 3) = cols;
    bsep_.segment<3>(o) = (R * bsep_.segment<3>(o)).eval();
  }
  for (int j = 0; j < f; ++j)
    for (int i = 0; i <= j; ++i) Hs(i, j) = full(i, j);
  for (int l = 0; l < num_lm_; ++l) {
    if (!hinted_landmark(l)) continue;
    const int e = lm_dim_[l];
    for (int a = lm_cpl_begin_[l]; a < lm_cpl_begin_[l + 1]; ++a) {
      bool moved = false;
      for (int k = 0; k < n; ++k) moved = moved || blocks_[ids[k]].index == cpl_row_[a];
      if (!moved) continue;
      Eigen::Map<Eigen::Matrix<double, 3, Eigen::Dynamic, Eigen::RowMajor, 3, 3>> v(v_ + cpl_v_[a], 3, e);
      v = (R * v).eval();
    }
  }
}

// As linearize_marginalized(), with the marginalized landmarks' terms (Hsep_, bsep_, and their
// H_ll, g_l, V, which the steps only read) taken from the last linearization: the other
// residuals and priors touching marginalized blocks are linearized, then the landmarks eliminated.
SolverStatus Problem::reuse_marginalized() {
  if (callback_ != nullptr) callback_->prepare_for_evaluation();
  zero_upper(H_.m());
  b_.setZero();
  add_separated();
  // The blocks the kept terms reach, as accumulating them would have marked them.
  for (int l = 0; l < num_lm_; ++l) {
    if (!marg_[lm_block_[l]]) continue;
    for (int q = lm_res_begin_[l]; q < lm_res_begin_[l + 1]; ++q) {
      const Residual& rb = residuals_[lm_res_[q]];
      for (int j = 0; j < rb.num_blocks; ++j) touched_[rb.blocks[j]] = touched_[rb.blocks[j]] || rb.variable[j];
    }
  }
  mark_touched_ = true;
  const SolverStatus st = accumulate_marginalized(true);
  mark_touched_ = false;
  return st;
}

// Landmark l's residuals accumulated into its own blocks and H_, b_ (eliminated later).
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
  return !lifted || finish_lift(l);
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
  // The upper triangle only (the prior reads no other), each entry summed as the lazy product
  // sums it: T(i, 0) H(j, 0) + T(i, 1) H(j, 1) + ..., then subtracted.
  MatrixMap S = S_.m();
  for (int j = 0; j < dk; ++j)
    for (int i = 0; i <= j; ++i) {
      double s = T_(i, 0) * Hkm_(j, 0);
      for (int k = 1; k < dm; ++k) s += T_(i, k) * Hkm_(j, k);
      S(i, j) -= s;
    }
  rhs_.noalias() -= T_.lazyProduct(dx_);
  return SolverStatus::kOk;
}

}  // namespace ums::solver
