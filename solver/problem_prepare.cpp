// Problem::prepare(): the structure every pass reuses until the problem changes (docs/solver.md,
// "Reduced ordering"): block ordering and offsets, residuals grouped by landmark, the landmark ->
// reduced-block couplings merged into segments, and the tail envelope of the reduced system.
#include "solver/problem.hpp"

#include <algorithm>

namespace ums::solver {

SolverStatus Problem::prepare() {
  if (prepared_) return SolverStatus::kOk;
  sep_valid_ = false;  // the kept marginalization terms belong to the layout being replaced
  SolverStatus st = order_blocks();
  if (st != SolverStatus::kOk) return st;
  group_residuals();
  assign_lifts();
  st = build_couplings();
  if (st != SolverStatus::kOk) return st;
  mark_fixed_priors();
  build_tail_envelope();
  resize_workspace();
  assign_kept_rows();
  prepared_ = true;
  return SolverStatus::kOk;
}

// touched_[block]: the block shares a residual with a variable eliminated block (a landmark).
void Problem::mark_landmark_coupled() {
  for (int i = 0; i < num_blocks_; ++i) touched_[i] = false;
  for (int k = 0; k < num_residuals_; ++k) {
    Residual& rb = residuals_[k];
    bool has_lm = false;
    for (int j = 0; j < rb.num_blocks; ++j) {
      const Block& b = blocks_[rb.blocks[j]];
      has_lm = has_lm || (b.eliminate && !b.constant);
    }
    rb.lm_coupled = has_lm;
    if (!has_lm) continue;
    for (int j = 0; j < rb.num_blocks; ++j) touched_[rb.blocks[j]] = true;
  }
}

// Reduced ordering: blocks seen by landmarks (poses, extrinsics) first, in declaration order,
// then the others (speed-biases, time offsets; order_tail). The frames observing one landmark
// then occupy contiguous rows, so its couplings merge into one or two long segments: the Schur
// updates and the accumulation touch fewer, denser parts of the reduced matrix. Landmarks get
// their slots.
SolverStatus Problem::order_blocks() {
  n_red_ = 0;
  num_lm_ = 0;
  mark_landmark_coupled();
  for (int i = 0; i < num_blocks_; ++i) {
    Block& b = blocks_[i];
    b.index = -1;
    if (b.constant) continue;
    if (b.eliminate) {
      if (num_lm_ >= capacity::kMaxEliminatedBlocks) return SolverStatus::kFull;
      b.index = num_lm_;
      lm_block_[num_lm_] = static_cast<std::int16_t>(i);
      lm_dim_[num_lm_] = b.tangent;
      ++num_lm_;
    } else if (touched_[i]) {
      if (n_red_ + b.tangent > capacity::kMaxReducedDim) return SolverStatus::kFull;
      b.index = n_red_;
      n_red_ += b.tangent;
    }
  }
  n_front_ = n_red_;
  return order_tail();
}

// The first front row a residual or prior couples to each tail block (mark_[block]; n_front_
// when none). Scratch: build_couplings() resets mark_ afterwards.
void Problem::first_front_rows() {
  for (int i = 0; i < num_blocks_; ++i) mark_[i] = n_front_;
  // One pass finds the front rows and whether there is a tail block at all: a landmark's
  // residuals, nearly all of them, have none, and stop there.
  auto visit = [this](const std::int16_t* ids, int n) {
    int lo = n_front_;
    bool tail = false;
    for (int a = 0; a < n; ++a) {
      const Block& b = blocks_[ids[a]];
      if (b.constant || b.eliminate) continue;
      if (b.index >= 0) {
        lo = std::min(lo, b.index);
      } else {
        tail = true;
      }
    }
    if (!tail) return;
    for (int a = 0; a < n; ++a) {
      const Block& b = blocks_[ids[a]];
      if (!b.constant && !b.eliminate && b.index < 0) mark_[ids[a]] = std::min(mark_[ids[a]], lo);
    }
  };
  // A residual with a variable landmark has none: its variable reduced blocks are all front
  // blocks (mark_landmark_coupled).
  for (int k = 0; k < num_residuals_; ++k)
    if (!residuals_[k].lm_coupled) visit(residuals_[k].blocks, residuals_[k].num_blocks);
  for (int p = 0; p < num_priors_; ++p) visit(priors_[p].blocks, priors_[p].prior->num_blocks());
}

// Tail blocks by their first coupled front row, latest first; among equals, the later declared
// first. The speed-biases of an IMU chain (declared oldest first, poses likewise) then come
// newest first, a chain again, with the oldest, which the marginal prior couples to every pose,
// last: the tail's elimination fills X = U^-T B^T (rows: front) as a staircase, each column
// non-zero only from tail_front_first_ on (factor_tail), instead of filling it completely from
// the first column on.
SolverStatus Problem::order_tail() {
  first_front_rows();
  int order[capacity::kMaxReducedDim];
  int n = 0;
  for (int i = num_blocks_ - 1; i >= 0; --i) {
    const Block& b = blocks_[i];
    if (b.constant || b.eliminate || b.index >= 0) continue;
    if (n == capacity::kMaxReducedDim) return SolverStatus::kFull;
    // Insertion sort (a handful of blocks; std::stable_sort may allocate).
    int at = n++;
    while (at > 0 && mark_[order[at - 1]] < mark_[i]) {
      order[at] = order[at - 1];
      --at;
    }
    order[at] = i;
  }
  for (int k = 0; k < n; ++k) {
    Block& b = blocks_[order[k]];
    if (n_red_ + b.tangent > capacity::kMaxReducedDim) return SolverStatus::kFull;
    b.index = n_red_;
    for (int t = 0; t < b.tangent; ++t) tail_front_first_[n_red_ + t] = mark_[order[k]];
    n_red_ += b.tangent;
  }
  return SolverStatus::kOk;
}

// A residual's landmark slot, fixed flag, cached block data and fast-path eligibility.
void Problem::classify_residual(Residual& rb) {
  // In locals, written once at the end: rb's byte-sized fields alias everything, so storing them
  // as the loop went made the compiler reload the blocks after every store.
  int landmark = -1, lm_pos = -1, num_sorted = 0;
  bool fixed = true;
  // Fast-path eligibility: 2 rows, variable reduced blocks all 6-dof, at most one 1-dof
  // eliminated block; blocks sorted by reduced row.
  bool fast2 = rb.rows == 2;
  std::int8_t sorted[capacity::kMaxBlocksPerResidual] = {};
  int sorted_row[capacity::kMaxBlocksPerResidual];
  for (int j = 0; j < rb.num_blocks; ++j) {
    const Block& b = blocks_[rb.blocks[j]];
    rb.params[j] = b.x;
    rb.tangent[j] = static_cast<std::int8_t>(b.tangent);
    rb.variable[j] = !b.constant;
    if (b.constant) continue;
    fixed = false;
    if (b.eliminate) {
      landmark = b.index;
      lm_pos = j;
      fast2 = fast2 && b.tangent == 1;
      continue;
    }
    fast2 = fast2 && b.tangent == 6;
    int p = num_sorted++;
    while (p > 0 && sorted_row[p - 1] > b.index) {
      sorted[p] = sorted[p - 1];
      sorted_row[p] = sorted_row[p - 1];
      --p;
    }
    sorted[p] = static_cast<std::int8_t>(j);
    sorted_row[p] = b.index;
  }
  rb.landmark = static_cast<std::int16_t>(landmark);
  rb.fixed = fixed;
  rb.fast2 = fast2;
  rb.lm_pos = static_cast<std::int8_t>(lm_pos);
  rb.num_sorted = static_cast<std::int8_t>(num_sorted);
  // The whole fixed-size array (the entries past num_sorted are zeros, never read): a variable
  // count became a memcpy call per residual.
  std::copy(sorted, sorted + capacity::kMaxBlocksPerResidual, rb.sorted);
}

// Residuals grouped by landmark (CSR), the rest in a free list.
void Problem::group_residuals() {
  for (int l = 0; l <= num_lm_; ++l) lm_res_begin_[l] = 0;
  num_free_res_ = 0;
  for (int k = 0; k < num_residuals_; ++k) {
    Residual& rb = residuals_[k];
    classify_residual(rb);
    if (rb.landmark >= 0) {
      ++lm_res_begin_[rb.landmark + 1];
    } else if (!rb.fixed) {
      free_res_[num_free_res_++] = k;
    }
  }
  for (int l = 0; l < num_lm_; ++l) lm_res_begin_[l + 1] += lm_res_begin_[l];
  int fill[capacity::kMaxEliminatedBlocks];
  for (int l = 0; l < num_lm_; ++l) fill[l] = lm_res_begin_[l];
  for (int k = 0; k < num_residuals_; ++k)
    if (residuals_[k].landmark >= 0) lm_res_[fill[residuals_[k].landmark]++] = k;
}

// lm_lift_[l] for the landmarks whose lift applies (its host variable and 6-dof, the landmark
// variable and 1-dof) and lift_pos for their residuals that take point Jacobians: 2 rows over
// 6-dof reduced blocks (fast2), the host among them.
void Problem::assign_lifts() {
  for (int l = 0; l < num_lm_; ++l) {
    const Block& lb = blocks_[lm_block_[l]];
    lm_lift_[l] = -1;
    if (lb.lift < 0 || lm_dim_[l] != 1) continue;
    const Block& host = blocks_[lifts_[lb.lift].blocks[0]];
    if (host.constant || host.tangent != 6) continue;
    lm_lift_[l] = lb.lift;
  }
  for (int k = 0; k < num_residuals_; ++k) {
    Residual& rb = residuals_[k];
    rb.lift_pos = -1;
    if (rb.landmark < 0 || lm_lift_[rb.landmark] < 0 || !rb.fast2 || rb.lm_pos < 0 ||
        !rb.fn->supports_point_jacobian())
      continue;
    const int host = lifts_[lm_lift_[rb.landmark]].blocks[0];
    for (int j = 0; j < rb.num_blocks; ++j)
      if (rb.blocks[j] == host) rb.lift_pos = static_cast<std::int8_t>(j);
  }
}

// Couplings landmark -> reduced blocks, sorted by row so every Schur block lands in the upper
// triangle; V storage laid out landmark after landmark.
SolverStatus Problem::build_couplings() {
  num_cpl_ = 0;
  num_seg_ = 0;
  int v_used = 0;
  for (int i = 0; i < num_blocks_; ++i) mark_[i] = -1;
  for (int l = 0; l < num_lm_; ++l) {
    lm_cpl_begin_[l] = num_cpl_;
    int ids[capacity::kMaxCouplingsPerLandmark];
    int n_ids = 0;
    SolverStatus st = collect_couplings(l, ids, &n_ids);
    if (st != SolverStatus::kOk) return st;
    st = add_couplings(l, ids, n_ids, &v_used);
    if (st != SolverStatus::kOk) return st;
    merge_segments(l, n_ids);
    num_cpl_ += n_ids;
  }
  lm_cpl_begin_[num_lm_] = num_cpl_;
  lm_seg_begin_[num_lm_] = num_seg_;
  v_used_ = v_used;
  return SolverStatus::kOk;
}

// The variable reduced blocks sharing a residual with landmark l, sorted by reduced row.
SolverStatus Problem::collect_couplings(int l, int* ids, int* n_ids) {
  // A residual's variable reduced blocks are its sorted ones (classify_residual). mark_[block]
  // == l: already listed for this landmark (no quadratic search).
  for (int q = lm_res_begin_[l]; q < lm_res_begin_[l + 1]; ++q) {
    const Residual& rb = residuals_[lm_res_[q]];
    for (int a = 0; a < rb.num_sorted; ++a) {
      const int id = rb.blocks[rb.sorted[a]];
      if (mark_[id] == l) continue;
      if (*n_ids >= capacity::kMaxCouplingsPerLandmark) return SolverStatus::kFull;
      mark_[id] = l;
      ids[(*n_ids)++] = id;
    }
  }
  std::sort(ids, ids + *n_ids,
            [this](int a, int b) { return blocks_[a].index < blocks_[b].index; });
  return SolverStatus::kOk;
}

// Coupling records of landmark l (row, size, offset of its V block) and every residual's slots.
SolverStatus Problem::add_couplings(int l, const int* ids, int n_ids, int* v_used) {
  if (num_cpl_ + n_ids > capacity::kMaxCouplings) return SolverStatus::kFull;
  for (int s = 0; s < n_ids; ++s) {
    const Block& b = blocks_[ids[s]];
    cpl_row_[num_cpl_ + s] = b.index;
    cpl_dim_[num_cpl_ + s] = b.tangent;
    cpl_v_[num_cpl_ + s] = *v_used;
    *v_used += b.tangent * lm_dim_[l];
    if (*v_used > capacity::kMaxCouplingEntries) return SolverStatus::kFull;
  }
  for (int s = 0; s < n_ids; ++s) slot_of_[ids[s]] = num_cpl_ + s;
  // Every sorted block of the landmark's residuals is listed; the others (constant, the landmark)
  // have no slot.
  for (int q = lm_res_begin_[l]; q < lm_res_begin_[l + 1]; ++q) {
    Residual& rb = residuals_[lm_res_[q]];
    for (int j = 0; j < rb.num_blocks; ++j) rb.slot[j] = -1;
    for (int a = 0; a < rb.num_sorted; ++a) {
      const int j = rb.sorted[a];
      rb.slot[j] = static_cast<std::int16_t>(slot_of_[rb.blocks[j]]);
    }
  }
  return SolverStatus::kOk;
}

// Landmark l's couplings with adjacent rows merged into segments.
void Problem::merge_segments(int l, int n_ids) {
  lm_seg_begin_[l] = num_seg_;
  for (int s = 0; s < n_ids; ++s) {
    const int c = num_cpl_ + s;
    if (s > 0 && seg_row_[num_seg_ - 1] + seg_len_[num_seg_ - 1] == cpl_row_[c]) {
      seg_len_[num_seg_ - 1] += cpl_dim_[c];
    } else {
      seg_row_[num_seg_] = cpl_row_[c];
      seg_len_[num_seg_] = cpl_dim_[c];
      seg_v_[num_seg_] = cpl_v_[c];
      ++num_seg_;
    }
  }
}

// A prior over constant blocks only is evaluated once per solve (fixed cost).
void Problem::mark_fixed_priors() {
  for (int p = 0; p < num_priors_; ++p) {
    PriorRef& pr = priors_[p];
    pr.fixed = true;
    for (int i = 0; i < pr.prior->num_blocks(); ++i)
      if (!blocks_[pr.blocks[i]].constant) pr.fixed = false;
  }
}

// Widens the tail envelope for a coupling between blocks ia and ic (both variable tail blocks).
void Problem::couple_tail(int ia, int ic) {
  const Block& ba = blocks_[ia];
  const Block& bc = blocks_[ic];
  if (ba.constant || bc.constant || ba.eliminate || bc.eliminate) return;
  if (ba.index < n_front_ || bc.index < n_front_) return;
  const int lo = std::min(ba.index, bc.index);
  const Block& hi = ba.index < bc.index ? bc : ba;
  for (int t = 0; t < hi.tangent; ++t)
    env_first_[hi.index + t] = std::min(env_first_[hi.index + t], lo);
}

// Envelope of the tail (rows >= n_front_): only free residuals and priors reach tail blocks.
void Problem::build_tail_envelope() {
  for (int i = 0; i < num_blocks_; ++i) {
    const Block& b = blocks_[i];
    if (b.constant || b.eliminate || b.index < n_front_) continue;
    for (int t = 0; t < b.tangent; ++t) env_first_[b.index + t] = b.index;
  }
  for (int q = 0; q < num_free_res_; ++q) {
    const Residual& rb = residuals_[free_res_[q]];
    for (int a = 0; a < rb.num_blocks; ++a)
      for (int c = a + 1; c < rb.num_blocks; ++c) couple_tail(rb.blocks[a], rb.blocks[c]);
  }
  for (int p = 0; p < num_priors_; ++p) {
    const PriorRef& pr = priors_[p];
    if (pr.fixed) continue;
    for (int a = 0; a < pr.prior->num_blocks(); ++a)
      for (int c = a + 1; c < pr.prior->num_blocks(); ++c) couple_tail(pr.blocks[a], pr.blocks[c]);
  }
  // Column j of X takes its fill from the tail columns its envelope reaches (factor_tail).
  for (int j = n_front_; j < n_red_; ++j)
    for (int k = env_first_[j]; k < j; ++k) tail_front_first_[j] = std::min(tail_front_first_[j], tail_front_first_[k]);
  const int m = n_red_ - n_front_;
  long env = 0;
  for (int j = n_front_; j < n_red_; ++j) env += j - env_first_[j] + 1;
  // Worth it when the tail's envelope is well below its dense triangle (block-tridiagonal IMU
  // chain: ~2 blocks per column, 26 % of the triangle for 11 frames, 53 % for 5); a dense tail
  // (e.g. a prior over every speed-bias) is factored as a whole.
  split_ = n_front_ > 0 && m > 0 && 10 * env <= 3L * m * (m + 1);
}

// Offsets of the residuals' rows in a kept_ buffer: every residual a linearization visits (one
// with a variable block), in declaration order, while they fit.
void Problem::assign_kept_rows() {
  kept_valid_ = false;
  int used = 0;
  for (int k = 0; k < num_residuals_; ++k) {
    const Residual& rb = residuals_[k];
    const bool fits = !rb.fixed && used + rb.rows <= capacity::kMaxKeptResidualRows;
    kept_off_[k] = fits ? used : -1;
    if (fits) used += rb.rows;
  }
}

void Problem::resize_workspace() {
  H_.resize(n_red_, n_red_);
  Hsep_.resize(n_red_, n_red_);
  bsep_.resize(n_red_);
  S_.resize(n_red_, n_red_);
  b_.resize(n_red_);
  rhs_.resize(n_red_);
  dx_.resize(n_red_);
  scale_red_.resize(n_red_);
  d_red_.resize(n_red_);
}

}  // namespace ums::solver
