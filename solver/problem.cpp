#include "solver/problem.hpp"

#include <algorithm>
#include <cmath>

#include "solver/finite.hpp"

namespace ums::solver {

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
