#pragma once
// Puts a camera whose clock is offset from the IMU's (t_imu = t_cam + td, the rig's td_s) back in
// IMU-time order before the estimator: the estimator closes each frame's IMU interval with the
// samples that arrived before the frame, so a frame must come after every sample older than it
// and before every sample newer.
//
//   td > 0: a frame arrives before the IMU has reached its time. It is copied and held until the
//           first sample at or after its time has gone on (or the next frame comes: then it goes
//           on as it is, counted in frames_unaligned; td must stay below a frame period; a frame
//           larger than the rig's cameras is not held either).
//   td < 0: a frame arrives after IMU samples newer than it. Every sample is held back by |td|
//           (kHeldImuSamples at most: the oldest is let go early, counted), and a frame first
//           releases the samples not newer than it.
//   td = 0: everything passes straight through (no copy, no delay).
// The frames going out are already on the IMU clock (StereoFrame::td_ns says by how much).
// With a range (estimate_td), set_td_ns moves the offset within calibration +- range as the
// estimator refines it, so that each new frame is stamped at the image's best-known IMU time and
// little offset is left for the window to model to first order (VINS-Fusion does the same). Both
// kinds of holding are then allocated; a frame that the IMU released under an older, larger
// offset has already overtaken goes on at that sample's time (counted in frames_restamped). Allocates
// in the constructor only.

#include <cstdint>
#include <memory>

#include "core/common/capacity.hpp"
#include "core/common/measurement_sink.hpp"
#include "core/common/ring_buffer.hpp"

namespace ums {

struct TimeAlignerCounters {
  std::uint64_t frames_held = 0;           // td > 0: waited for the IMU to reach them
  std::uint64_t frames_unaligned = 0;      // went on before the IMU reached them (td too large)
  std::uint64_t imu_released_early = 0;    // td < 0: let go before |td| had passed (ring full)
  std::uint64_t frames_restamped = 0;      // moved to a sample already let go (the offset fell)
};

class TimeAligner {
 public:
  // td_ns: t_imu = t_cam + td. max_width, max_height: the largest image to hold (td > 0).
  // range_ns: how far set_td_ns may move the offset from td_ns (0: it stays).
  TimeAligner(std::int64_t td_ns, int max_width, int max_height, std::int64_t range_ns = 0);
  TimeAligner(const TimeAligner&) = delete;
  TimeAligner& operator=(const TimeAligner&) = delete;

  // In arrival order; out gets them in IMU-time order.
  void on_imu(const ImuSample& sample, MeasurementSink* out);
  // frame: stamped on the camera clock.
  void on_stereo(const StereoFrame& frame, MeasurementSink* out);
  // End of the input: what is still held goes on (a held frame counted as not aligned).
  void flush(MeasurementSink* out);
  const TimeAlignerCounters& counters() const { return counters_; }
  // The offset for the frames from now on, clamped to the range; returns the one in use.
  std::int64_t set_td_ns(std::int64_t td_ns);
  std::int64_t td_ns() const { return td_ns_; }

 private:
  void hold_frame(const StereoFrame& frame_imu_clock);
  bool fits(const StereoFrame& frame) const;
  void release_imu_until(std::int64_t t_ns, MeasurementSink* out);
  void emit_imu(const ImuSample& sample, MeasurementSink* out);
  void emit_held_frame(MeasurementSink* out);

  std::int64_t td0_ns_, range_ns_;
  std::int64_t td_ns_;
  std::int64_t newest_imu_t_ns_ = INT64_MIN;
  std::int64_t released_imu_t_ns_ = INT64_MIN;  // the newest sample passed on
  std::unique_ptr<RingBuffer<ImuSample, capacity::kHeldImuSamples>> held_imu_;  // td may be < 0
  std::unique_ptr<std::uint8_t[]> left_, right_;                               // td may be > 0
  std::size_t image_bytes_ = 0;
  bool frame_held_ = false;
  StereoFrame held_frame_;
  TimeAlignerCounters counters_;
};

}  // namespace ums
