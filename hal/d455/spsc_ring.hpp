#pragma once
// Lock-free single-producer / single-consumer ring with fixed capacity, for the live app's
// capture -> estimator and IMU -> estimator hand-offs. push on a full ring drops the new item and
// counts it (the producer is a device thread that must never block); pop never blocks.
// One thread may call push, one other thread may call pop; everything else is thread-safe reads.

#include <array>
#include <atomic>
#include <cstddef>
#include <cstdint>

#include "core/common/status.hpp"

namespace ums::d455 {

template <typename T, std::size_t N>
class SpscRing {
  static_assert(N >= 2 && (N & (N - 1)) == 0, "capacity must be a power of two");

 public:
  static constexpr std::size_t kCapacity = N;

  // Producer thread only.
  Status push(const T& value) {
    const std::size_t head = head_.load(std::memory_order_relaxed);
    if (head - tail_.load(std::memory_order_acquire) >= N) {
      overflows_.fetch_add(1, std::memory_order_relaxed);
      return Status::kFull;
    }
    slots_[head & (N - 1)] = value;
    head_.store(head + 1, std::memory_order_release);  // publishes the slot write
    return Status::kOk;
  }

  // Consumer thread only.
  Status pop(T* out) {
    const std::size_t tail = tail_.load(std::memory_order_relaxed);
    if (tail == head_.load(std::memory_order_acquire)) return Status::kEmpty;
    *out = slots_[tail & (N - 1)];
    tail_.store(tail + 1, std::memory_order_release);  // frees the slot for the producer
    return Status::kOk;
  }

  std::size_t size() const {
    return head_.load(std::memory_order_acquire) - tail_.load(std::memory_order_acquire);
  }
  std::uint64_t overflows() const { return overflows_.load(std::memory_order_relaxed); }

 private:
  // Producer and consumer indices on separate cache lines: no false sharing between the threads.
  alignas(64) std::atomic<std::size_t> head_{0};
  alignas(64) std::atomic<std::size_t> tail_{0};
  alignas(64) std::atomic<std::uint64_t> overflows_{0};
  std::array<T, N> slots_{};
};

}  // namespace ums::d455
