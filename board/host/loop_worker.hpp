#pragma once
// The loop closer's costly step on its own thread (issue 17: loop work off the frame path).
//
// On the frame thread: a keyframe image is described (BRIEF at its tracked features, ~1.5 ms per
// keyframe on the host) and a leaving keyframe is prepared (its described 3D features copied into
// a slot of a fixed queue). On the loop thread: keeping, querying, verifying and the pose-graph
// solve (up to ~200 ms at full capacity), one keyframe at a time, in arrival order. The map frame
// the frame thread reads (MapFrameSource) is the placement published after each keyframe.
//
// When the queue is full, a live run drops the keyframe (counted: a frame is never held up for
// loop closure); a replay waits for a slot (nothing lost). Nothing allocates after construction.
//
// Tightly coupled relocation crosses the threads too: an accepted loop's request is published
// for the frame thread (the newest replaces one not yet taken), and the window's results are
// queued back (kResults; the oldest is dropped, counted, when the loop thread falls behind).

#include <condition_variable>
#include <cstdint>
#include <memory>
#include <mutex>
#include <thread>

#include "core/common/capacity.hpp"
#include "core/estimator/keyframe_sink.hpp"
#include "core/loop/loop_steps.hpp"
#include "core/loop/map_frame_source.hpp"
#include "core/pipeline/keyframe_image_sink.hpp"

namespace ums::cli {

enum class QueueFull : std::uint8_t { kWait, kDrop };

struct LoopWorkerStats {
  std::uint64_t queued = 0;        // keyframes handed to the loop thread
  std::uint64_t dropped = 0;       // the queue was full (kDrop)
  std::uint64_t waits = 0;         // the frame thread waited for a slot (kWait)
  std::uint64_t max_depth = 0;     // most keyframes waiting at once
  std::uint64_t relocation_results_dropped = 0;
};

class LoopWorker final : public KeyframeSink,
                         public KeyframeImageSink,
                         public loop::MapFrameSource,
                         public RelocationLink {
 public:
  // steps, images: not owned (the LoopCloser is both). add_keyframe and placement run on the loop
  // thread between construction and stop(); images and prepare on the caller's.
  LoopWorker(loop::LoopSteps& steps, KeyframeImageSink& images, QueueFull when_full);
  ~LoopWorker() override;
  LoopWorker(const LoopWorker&) = delete;
  LoopWorker& operator=(const LoopWorker&) = delete;

  void on_keyframe_image(FrameId id, std::int64_t t_ns, const ImageView& left,
                         const FrameFeatures& features) override;
  void on_keyframe(const MarginalizedKeyframe& keyframe) override;
  bool map_from_odometry(std::uint32_t odometry_epoch, Eigen::Isometry3d* T_map_odom) const override;
  std::uint32_t corrections() const override;
  // Frame thread: the newest published request; a result for the loop thread.
  bool take_relocation(RelocationRequest* out) override;
  void on_relocated(const RelocationResult& result) override;

  // Finishes the queued keyframes and ends the thread (then the closer is the caller's again).
  void stop();
  LoopWorkerStats stats() const;

 private:
  static constexpr std::size_t kResults = 4;
  void run();
  void relocate(std::unique_lock<std::mutex>& lock);  // one queued result, lock held on entry

  loop::LoopSteps& steps_;
  KeyframeImageSink& images_;
  const QueueFull when_full_;
  std::unique_ptr<loop::LoopKeyframe[]> queue_;
  mutable std::mutex mutex_;
  std::condition_variable has_work_, has_room_;
  std::size_t head_ = 0, count_ = 0;
  bool stopping_ = false;
  loop::MapPlacement published_;
  std::unique_ptr<RelocationRequest> request_made_;       // loop thread's
  std::unique_ptr<RelocationRequest> request_published_;  // under mutex_
  bool has_request_ = false;
  RelocationResult results_[kResults];
  std::size_t results_head_ = 0, n_results_ = 0;
  LoopWorkerStats stats_;
  std::thread thread_;  // last: starts once everything above exists
};

}  // namespace ums::cli
