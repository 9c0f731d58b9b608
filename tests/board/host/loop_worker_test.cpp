// The loop thread (board/host/loop_worker): keyframes reach the closer's costly step in arrival
// order and nothing is lost when the caller may wait; a live run's frame thread never waits (a
// keyframe the busy thread cannot take is dropped and counted); the map frame the frame thread
// reads is the one published after each keyframe; handing keyframes over allocates nothing.
#include "board/host/loop_worker.hpp"

#include <catch2/catch.hpp>
#include <atomic>
#include <chrono>
#include <functional>
#include <mutex>
#include <thread>
#include <vector>

#include "profiling/alloc_counter.hpp"

namespace ums::cli {
namespace {

// Records the keyframes it is given; add_keyframe can be held until release(). Each keyframe
// moves the map frame by 1 m in x and counts a correction; an even keyframe makes a relocation
// request (query = its id), and a relocation result moves the map frame by 10 m in y.
class FakeSteps final : public loop::LoopSteps, public KeyframeImageSink {
 public:
  explicit FakeSteps(bool held) : held_(held) { added_.reserve(1000); }
  void prepare(const MarginalizedKeyframe& k, loop::LoopKeyframe* out) const override {
    out->id = k.id;
    out->t_ns = k.t_ns;
    out->odometry_epoch = k.odometry_epoch;
  }
  void add_keyframe(const loop::LoopKeyframe& k) override {
    started_ = true;
    while (held_) std::this_thread::yield();
    const std::lock_guard<std::mutex> lock(mutex_);
    added_.push_back(k.id);
    placement_.started = placement_.placed = true;
    placement_.epoch = k.odometry_epoch;
    placement_.T_map_odom.translation().x() += 1.0;
    ++placement_.corrections;
    if (k.id % 2 == 0) request_ = k.id;
  }
  bool take_relocation(RelocationRequest* out) override {
    if (request_ == kNoFrame) return false;
    out->query = request_;
    request_ = kNoFrame;
    return true;
  }
  void on_relocated(const RelocationResult& r) override {
    const std::lock_guard<std::mutex> lock(mutex_);
    relocated_.push_back(r.query);
    placement_.T_map_odom.translation().y() += 10.0;
    ++placement_.corrections;
  }
  std::vector<FrameId> relocated() const {
    const std::lock_guard<std::mutex> lock(mutex_);
    return relocated_;
  }
  loop::MapPlacement placement() const override {
    const std::lock_guard<std::mutex> lock(mutex_);
    return placement_;
  }
  void on_keyframe_image(FrameId, std::int64_t, const ImageView&, const FrameFeatures&) override { ++images_; }

  void release() { held_ = false; }
  bool started() const { return started_; }
  std::vector<FrameId> added() const {
    const std::lock_guard<std::mutex> lock(mutex_);
    return added_;
  }
  int images() const { return images_; }

 private:
  std::atomic<bool> held_;
  std::atomic<bool> started_{false};
  std::atomic<int> images_{0};
  mutable std::mutex mutex_;
  std::vector<FrameId> added_;
  std::vector<FrameId> relocated_;
  FrameId request_ = kNoFrame;  // the loop thread's
  loop::MapPlacement placement_;
};

MarginalizedKeyframe keyframe(FrameId id) {
  MarginalizedKeyframe k;
  k.id = id;
  k.t_ns = static_cast<std::int64_t>(id) * 50000000;
  k.odometry_epoch = 3;
  k.gravity_aligned = true;
  return k;
}

void wait_until(const std::function<bool()>& done) {
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(60);
  while (!done() && std::chrono::steady_clock::now() < deadline) std::this_thread::sleep_for(std::chrono::milliseconds(1));
}

}  // namespace

TEST_CASE("LoopWorker: every keyframe reaches the loop thread in order when the caller may wait", "[loop]") {
  FakeSteps steps(true);
  LoopWorker worker(steps, steps, QueueFull::kWait);
  std::atomic<int> fed{0};
  std::thread feeder([&] {
    for (FrameId id = 1; id <= 40; ++id) {
      worker.on_keyframe(keyframe(id));
      ++fed;
    }
  });
  wait_until([&] { return fed >= static_cast<int>(capacity::kLoopQueue); });
  std::this_thread::sleep_for(std::chrono::milliseconds(50));
  // The thread is held on the first keyframe: the feeder waits once the queue is full.
  CHECK(fed == static_cast<int>(capacity::kLoopQueue));
  steps.release();
  feeder.join();
  worker.stop();
  std::vector<FrameId> expected;
  for (FrameId id = 1; id <= 40; ++id) expected.push_back(id);
  CHECK(steps.added() == expected);
  const LoopWorkerStats st = worker.stats();
  CHECK(st.queued == 40);
  CHECK(st.dropped == 0);
  CHECK(st.waits >= 1);
  CHECK(st.max_depth == capacity::kLoopQueue);
}

TEST_CASE("LoopWorker: a live run's frame thread never waits, what the busy thread cannot take is counted", "[loop]") {
  FakeSteps steps(true);
  LoopWorker worker(steps, steps, QueueFull::kDrop);
  worker.on_keyframe(keyframe(1));
  wait_until([&] { return steps.started(); });
  REQUIRE(steps.started());  // keyframe 1 is on the loop thread, held
  for (FrameId id = 2; id <= 20; ++id) worker.on_keyframe(keyframe(id));  // returns: nothing waits
  // The keyframe on the loop thread keeps its slot until it is done.
  const LoopWorkerStats held = worker.stats();
  CHECK(held.queued == capacity::kLoopQueue);
  CHECK(held.dropped == 20 - capacity::kLoopQueue);
  CHECK(held.waits == 0);
  steps.release();
  worker.stop();
  std::vector<FrameId> expected;
  for (FrameId id = 1; id <= capacity::kLoopQueue; ++id) expected.push_back(id);
  CHECK(steps.added() == expected);  // the oldest kept, in order: the newest were dropped
}

TEST_CASE("LoopWorker: the frame thread reads the map frame published after each keyframe", "[loop]") {
  FakeSteps steps(false);
  LoopWorker worker(steps, steps, QueueFull::kWait);
  Eigen::Isometry3d T_map_odom;
  CHECK_FALSE(worker.map_from_odometry(3, &T_map_odom));  // nothing kept yet: not placed
  for (FrameId id = 1; id <= 5; ++id) worker.on_keyframe(keyframe(id));
  wait_until([&] { return worker.corrections() == 5; });
  CHECK(worker.corrections() == 5);
  REQUIRE(worker.map_from_odometry(3, &T_map_odom));
  CHECK(T_map_odom.translation().x() == Approx(5.0));  // m: one per keyframe
  CHECK_FALSE(worker.map_from_odometry(4, &T_map_odom));  // another odometry frame
  worker.stop();
}

TEST_CASE("LoopWorker: relocation requests reach the frame thread, their results the loop thread", "[loop]") {
  FakeSteps steps(false);
  LoopWorker worker(steps, steps, QueueFull::kWait);
  RelocationRequest request;
  CHECK_FALSE(worker.take_relocation(&request));  // none made yet
  worker.on_keyframe(keyframe(1));
  worker.on_keyframe(keyframe(2));
  wait_until([&] { return worker.corrections() == 2; });
  REQUIRE(worker.take_relocation(&request));
  CHECK(request.query == 2);
  CHECK_FALSE(worker.take_relocation(&request));  // taken once
  // Keyframes 4 and 6 both request before the frame thread looks: the newer one wins.
  for (FrameId id = 3; id <= 6; ++id) worker.on_keyframe(keyframe(id));
  wait_until([&] { return worker.corrections() == 6; });
  REQUIRE(worker.take_relocation(&request));
  CHECK(request.query == 6);
  RelocationResult result;
  result.query = 6;
  worker.on_relocated(result);
  wait_until([&] { return worker.corrections() == 7; });
  Eigen::Isometry3d T_map_odom;
  REQUIRE(worker.map_from_odometry(3, &T_map_odom));
  CHECK(T_map_odom.translation().y() == Approx(10.0));  // m: the result was applied and published
  // Results the busy loop thread has not taken: the newest kResults kept, the oldest dropped.
  worker.stop();
  CHECK(steps.relocated() == std::vector<FrameId>{6});
}

TEST_CASE("LoopWorker: images are described on the caller's thread, handing keyframes over allocates nothing", "[loop]") {
  FakeSteps steps(false);
  LoopWorker worker(steps, steps, QueueFull::kWait);
  const MarginalizedKeyframe k = keyframe(7);
  const ImageView image{};
  const FrameFeatures features{};
  AllocScope scope;
  for (int i = 0; i < 50; ++i) {
    worker.on_keyframe_image(7, 0, image, features);
    worker.on_keyframe(k);
  }
  const auto allocations = scope.allocations();
  worker.stop();
  CHECK(steps.images() == 50);
  CHECK(worker.stats().queued == 50);
  if (alloc_counter_available()) CHECK(allocations == 0);
}

}  // namespace ums::cli
