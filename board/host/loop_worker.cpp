#include "board/host/loop_worker.hpp"

#include <algorithm>

namespace ums::cli {

LoopWorker::LoopWorker(loop::LoopSteps& steps, KeyframeImageSink& images, QueueFull when_full)
    : steps_(steps),
      images_(images),
      when_full_(when_full),
      queue_(new loop::LoopKeyframe[capacity::kLoopQueue]),
      published_(steps.placement()),
      request_made_(new RelocationRequest()),
      request_published_(new RelocationRequest()),
      thread_([this] { run(); }) {}

LoopWorker::~LoopWorker() { stop(); }

void LoopWorker::on_keyframe_image(FrameId id, std::int64_t t_ns, const ImageView& left,
                                   const FrameFeatures& features) {
  images_.on_keyframe_image(id, t_ns, left, features);
}

void LoopWorker::on_keyframe(const MarginalizedKeyframe& keyframe) {
  std::size_t tail = 0;
  {
    std::unique_lock<std::mutex> lock(mutex_);
    if (stopping_) return;
    if (count_ == capacity::kLoopQueue) {
      if (when_full_ == QueueFull::kDrop) {
        ++stats_.dropped;
        return;
      }
      ++stats_.waits;
      has_room_.wait(lock, [this] { return count_ < capacity::kLoopQueue; });
    }
    tail = (head_ + count_) % capacity::kLoopQueue;
  }
  // The slot past the queued ones is this thread's until it is counted in.
  steps_.prepare(keyframe, &queue_[tail]);
  {
    const std::lock_guard<std::mutex> lock(mutex_);
    ++count_;
    ++stats_.queued;
    stats_.max_depth = std::max<std::uint64_t>(stats_.max_depth, count_);
  }
  has_work_.notify_one();
}

void LoopWorker::run() {
  std::unique_lock<std::mutex> lock(mutex_);
  for (;;) {
    has_work_.wait(lock, [this] { return count_ > 0 || n_results_ > 0 || stopping_; });
    if (n_results_ > 0) {
      relocate(lock);
      continue;
    }
    if (count_ == 0) return;  // stopping with nothing left
    const loop::LoopKeyframe& k = queue_[head_];
    lock.unlock();
    steps_.add_keyframe(k);
    const loop::MapPlacement placement = steps_.placement();
    const bool made = steps_.take_relocation(request_made_.get());
    lock.lock();
    published_ = placement;
    if (made) {
      std::swap(request_made_, request_published_);
      has_request_ = true;
    }
    head_ = (head_ + 1) % capacity::kLoopQueue;
    --count_;
    has_room_.notify_one();
  }
}

void LoopWorker::relocate(std::unique_lock<std::mutex>& lock) {
  const RelocationResult r = results_[results_head_];
  results_head_ = (results_head_ + 1) % kResults;
  --n_results_;
  lock.unlock();
  steps_.on_relocated(r);
  const loop::MapPlacement placement = steps_.placement();
  lock.lock();
  published_ = placement;
}

bool LoopWorker::take_relocation(RelocationRequest* out) {
  const std::lock_guard<std::mutex> lock(mutex_);
  if (!has_request_) return false;
  *out = *request_published_;
  has_request_ = false;
  return true;
}

void LoopWorker::on_relocated(const RelocationResult& result) {
  {
    const std::lock_guard<std::mutex> lock(mutex_);
    if (stopping_) return;
    if (n_results_ == kResults) {
      results_head_ = (results_head_ + 1) % kResults;
      --n_results_;
      ++stats_.relocation_results_dropped;
    }
    results_[(results_head_ + n_results_) % kResults] = result;
    ++n_results_;
  }
  has_work_.notify_one();
}

void LoopWorker::stop() {
  {
    const std::lock_guard<std::mutex> lock(mutex_);
    stopping_ = true;
  }
  has_work_.notify_one();
  if (thread_.joinable()) thread_.join();
}

bool LoopWorker::map_from_odometry(std::uint32_t odometry_epoch, Eigen::Isometry3d* T_map_odom) const {
  const std::lock_guard<std::mutex> lock(mutex_);
  return published_.map_from_odometry(odometry_epoch, T_map_odom);
}

std::uint32_t LoopWorker::corrections() const {
  const std::lock_guard<std::mutex> lock(mutex_);
  return published_.corrections;
}

LoopWorkerStats LoopWorker::stats() const {
  const std::lock_guard<std::mutex> lock(mutex_);
  return stats_;
}

}  // namespace ums::cli
