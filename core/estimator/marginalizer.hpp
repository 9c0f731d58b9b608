#pragma once
// The marginalization prior of the sliding window (paper Sec. III-C) and the keyframe outlet.
// It owns the prior (square-root form, docs/solver.md) and the names of its blocks (FrameId for a
// frame's pose and speed-bias, camera for an extrinsic), adopts the result of marginalizing
// blocks out of a problem, takes a dropped frame out of the prior alone, and hands every
// keyframe that leaves the window to the KeyframeSink.

#include <cstdint>
#include <memory>

#include "core/estimator/block_table.hpp"
#include "core/estimator/frame_id.hpp"
#include "core/estimator/keyframe_sink.hpp"
#include "solver/capacity.hpp"

namespace ums {
namespace solver {
class Problem;
class MarginalPrior;
}  // namespace solver

class Window;
class LandmarkMap;

class Marginalizer {
 public:
  Marginalizer();
  ~Marginalizer();
  Marginalizer(const Marginalizer&) = delete;
  Marginalizer& operator=(const Marginalizer&) = delete;

  bool empty() const;
  void clear();
  const solver::MarginalPrior* prior() const { return prior_.get(); }
  int num_blocks() const;
  const BlockName& name(int i) const { return names_[i]; }

  // Marginalizes blocks `ids` of `problem` (linearized at its current values) into the new prior;
  // the prior's remaining blocks are named through `table`. False: the information is lost (the
  // prior is cleared), counted by the caller.
  bool adopt(solver::Problem& problem, const BlockTable& table, const int* ids, int n);
  // Takes frame `id` out of the prior alone (a problem of the prior only, built in `problem`).
  // True when the prior does not hold it.
  bool marginalize_frame(FrameId id, Window& window, solver::Problem& problem, BlockTable* table);

  void set_keyframe_sink(KeyframeSink* sink) { sink_ = sink; }
  // Hands the window frame at `pos` (leaving now) to the sink, with its observations and points.
  // odometry_epoch and gravity_aligned: MarginalizedKeyframe's.
  void emit_keyframe(const Window& window, int pos, const LandmarkMap& landmarks,
                     std::uint32_t odometry_epoch, bool gravity_aligned);
  std::uint64_t keyframes_emitted() const { return emitted_; }

 private:
  bool holds_frame(FrameId id) const;

  std::unique_ptr<solver::MarginalPrior> prior_;
  std::unique_ptr<solver::MarginalPrior> prior_next_;
  BlockName names_[solver::capacity::kMaxReducedBlocks];
  KeyframeSink* sink_ = nullptr;
  std::unique_ptr<MarginalizedKeyframe> record_;
  std::uint64_t emitted_ = 0;
};

}  // namespace ums
