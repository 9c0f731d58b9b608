#pragma once
// Hands measurements from one thread to another without locks, for `umsvins live`: the capture
// thread pushes into the bridge as a MeasurementSink, the estimator thread drains it into its own
// sink, in the same order. Frames are copied into a fixed set of slots allocated at start-up
// (source views die with the source's next frame); IMU samples travel by value.
//
// Full ring or no free frame slot: the new measurement is dropped and counted, the producer never
// blocks. Memory: capacity::kThreadBridgeEvents events + kThreadBridgeFrameSlots stereo pairs.

#include <cstdint>
#include <memory>

#include "core/common/capacity.hpp"
#include "core/common/measurement_sink.hpp"
#include "hal/d455/spsc_ring.hpp"

namespace ums::d455 {

class ThreadBridge final : public MeasurementSink {
 public:
  // Largest image the producer will push (px); slots are allocated here, once.
  ThreadBridge(int max_width, int max_height);

  // Producer thread.
  void on_imu(const ImuSample& sample) override;
  void on_stereo(const StereoFrame& frame) override;

  // Consumer thread: delivers up to max_events in push order; returns how many were delivered.
  std::size_t drain(MeasurementSink& sink, std::size_t max_events = SIZE_MAX);

  // Any thread.
  std::uint64_t imu_dropped() const { return imu_dropped_.load(std::memory_order_relaxed); }
  std::uint64_t frames_dropped() const { return frames_dropped_.load(std::memory_order_relaxed); }
  std::size_t pending() const { return events_.size(); }

 private:
  struct Event {
    bool is_frame = false;
    ImuSample imu;
    int slot = -1;
    std::int64_t t_ns = 0;
    std::uint64_t seq = 0;
    int width = 0, height = 0;
    bool has_right = false;
  };
  static constexpr std::size_t kSlots = capacity::kThreadBridgeFrameSlots;

  int max_width_, max_height_;
  std::unique_ptr<std::uint8_t[]> pixels_;           // kSlots x (left, right)
  SpscRing<Event, capacity::kThreadBridgeEvents> events_;  // producer -> consumer
  SpscRing<int, 2 * kSlots> free_slots_;             // consumer -> producer
  int spare_slot_ = -1;                              // producer only: a slot taken but not sent
  std::atomic<std::uint64_t> imu_dropped_{0};
  std::atomic<std::uint64_t> frames_dropped_{0};
};

}  // namespace ums::d455
