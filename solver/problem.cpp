// Problem set-up: blocks, residuals, priors (docs/solver.md). The other steps live in their own
// units: problem_prepare.cpp (structure), problem_linearize.cpp (residuals, H and b),
// problem_solve.cpp (Levenberg-Marquardt, Schur complement, factorization) and
// problem_marginalize.cpp.
#include "solver/problem.hpp"

#include <cmath>

#include "solver/finite.hpp"

namespace ums::solver {

void Problem::clear() {
  for (int i = 0; i < num_blocks_; ++i) hint_[i] = false;
  hinted_ = false;
  sep_valid_ = false;
  num_blocks_ = 0;
  num_residuals_ = 0;
  num_priors_ = 0;
  num_lifts_ = 0;
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
  b.lift = -1;
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

SolverStatus Problem::set_point_lift(const PointLift* lift, BlockId host, BlockId landmark, const BlockId* others,
                                     int n_others) {
  if (lift == nullptr || n_others < 0 || 2 + n_others > capacity::kMaxBlocksPerResidual)
    return SolverStatus::kInvalidInput;
  const auto valid = [this](BlockId id) { return id >= 0 && id < num_blocks_; };
  if (!valid(host) || !valid(landmark) || blocks_[host].eliminate || !blocks_[landmark].eliminate ||
      blocks_[landmark].lift >= 0)
    return SolverStatus::kInvalidInput;
  for (int i = 0; i < n_others; ++i)
    if (!valid(others[i])) return SolverStatus::kInvalidInput;
  if (num_lifts_ >= capacity::kMaxEliminatedBlocks) return SolverStatus::kFull;
  LiftRef& lr = lifts_[num_lifts_];
  lr.fn = lift;
  lr.blocks[0] = static_cast<std::int16_t>(host);
  lr.blocks[1] = static_cast<std::int16_t>(landmark);
  for (int i = 0; i < n_others; ++i) lr.blocks[2 + i] = static_cast<std::int16_t>(others[i]);
  lr.num_blocks = static_cast<std::int8_t>(2 + n_others);
  blocks_[landmark].lift = static_cast<std::int16_t>(num_lifts_++);
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

}  // namespace ums::solver
