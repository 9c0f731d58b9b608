#pragma once
// One time base for the pipeline: CLOCK_MONOTONIC nanoseconds. The D455 stamps frames (UVC PTS,
// capture-timing block) and IMU samples (IIO timestamp = device µs x 1000) with one free-running
// 32-bit device µs counter (notes §6.1); this file unwraps it and maps it onto the host clock, and
// drops anything that would go back in time.

#include <cstdint>

namespace ums::d455 {

// CLOCK_MONOTONIC now, ns.
std::int64_t monotonic_now_ns();

// Unwraps a 32-bit µs counter (period 2^32 µs ~ 71.6 min) into int64 µs. Steps are taken modulo
// 2^32 as signed: a step back is returned as is (the caller's order gate drops it), never a wrap.
class Unwrap32 {
 public:
  std::int64_t unwrap(std::uint32_t raw_us);
  void reset() { started_ = false; }

 private:
  bool started_ = false;
  std::uint32_t last_raw_ = 0;
  std::int64_t epoch_us_ = 0;  // unwrapped value of last_raw_
};

struct ClockMapOptions {
  // Allowed drift of the device crystal against the host clock, parts per million. The offset
  // estimate leaks upward at this rate so a device clock running slow is followed (a fast one is
  // followed by the minimum itself).
  double max_drift_ppm = 100.0;
  void validate() const;
};

// Device -> host mapping by the lower envelope of (host arrival - device stamp): transport adds
// latency, never removes it, so the smallest difference seen is the closest to the true offset.
// Early mapped times can be late by the first latencies; the order gate drops what that reorders.
class DeviceClockMap {
 public:
  explicit DeviceClockMap(const ClockMapOptions& options = {}) : options_(options) {}
  // One observation: device time (ns on the unwrapped device clock) and the host time at which
  // the data carrying it was received.
  void observe(std::int64_t device_ns, std::int64_t host_ns);
  bool ready() const { return have_offset_; }
  // Host (CLOCK_MONOTONIC) ns of a device time; device_ns unchanged until the first observation.
  std::int64_t to_host_ns(std::int64_t device_ns) const { return device_ns + offset_ns_; }
  std::int64_t offset_ns() const { return offset_ns_; }
  // The one unwrapper of the device's 32-bit µs counter, shared by frames and IMU samples so both
  // streams land in the same epoch.
  std::int64_t unwrap_us(std::uint32_t raw_us) { return unwrap_.unwrap(raw_us); }

 private:
  ClockMapOptions options_;
  Unwrap32 unwrap_;
  bool have_offset_ = false;
  std::int64_t offset_ns_ = 0;
  std::int64_t last_host_ns_ = 0;
};

// Passes strictly increasing timestamps; counts and refuses duplicates and steps back.
class OrderGate {
 public:
  bool accept(std::int64_t t_ns);
  std::uint64_t duplicates() const { return duplicates_; }
  std::uint64_t out_of_order() const { return out_of_order_; }
  std::int64_t last_ns() const { return last_ns_; }
  bool started() const { return started_; }

 private:
  bool started_ = false;
  std::int64_t last_ns_ = 0;
  std::uint64_t duplicates_ = 0;
  std::uint64_t out_of_order_ = 0;
};

}  // namespace ums::d455
