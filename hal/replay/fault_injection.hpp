#pragma once
// Sensor faults applied to a measurement stream on its way to the pipeline (`replay --fault`, and
// the fault tests): what real rigs do to an estimator, on any recorded or rendered flight, so that
// the expected behaviour (no crash, no NaN pose, a pose or an explicit "no pose" per frame,
// counted drops, back to VIO after the fault) can be checked with the flight's ground truth.
//
// A fault is KIND:START_S:DURATION_S[:PARAM], START_S from the stream's first stamp:
//   imu-gap        the IMU samples in the interval are lost
//   imu-nan        ... carry NaN (gyro and accel)
//   imu-huge       ... carry 1e9 (a sensor glitch)
//   imu-dup        ... each come twice (same stamp)
//   imu-swap       ... come in swapped pairs (out of order)
//   frame-gap      the stereo pairs in the interval are lost
//   frame-drop     ... each lost with probability PARAM (0..1, seeded: the same run twice)
//   frame-freeze   ... carry the images of the last pair before the interval (a stuck camera)
//   frame-dup      ... each come twice (same stamp)
//   right-lost     ... have no right image
//   blackout       ... are black in both cameras
//   clock-jump     every stamp in the interval moves by PARAM s (duration 0: to the end)
//   images-end     no pair from START_S on (the image stream ends before the IMU)
// Fixed memory: two image buffers when a fault needs them, allocated in the constructor.

#include <cstdint>
#include <memory>
#include <random>
#include <string>

#include "core/common/measurement_sink.hpp"

namespace ums::hal {

enum class FaultKind : std::uint8_t {
  kImuGap, kImuNan, kImuHuge, kImuDuplicate, kImuSwap,
  kFrameGap, kFrameDrop, kFrameFreeze, kFrameDuplicate, kRightLost, kBlackout,
  kClockJump, kImagesEnd,
};

struct Fault {
  FaultKind kind = FaultKind::kImuGap;
  double start_s = 0.0;     // s after the stream's first stamp
  double duration_s = 0.0;  // s (clock-jump: 0 = to the end; images-end: ignored)
  double param = 0.0;       // frame-drop: probability; clock-jump: s
};

// "imu-gap:20:0.5" -> Fault; false with a message naming the part that is wrong.
bool parse_fault(const std::string& spec, Fault* out, std::string* error);
const char* to_string(FaultKind kind);

struct FaultCounters {
  std::uint64_t imu_lost = 0, imu_corrupted = 0, imu_extra = 0, imu_reordered = 0;
  std::uint64_t frames_lost = 0, frames_altered = 0, frames_extra = 0;
  std::uint64_t restamped = 0;  // measurements moved by a clock jump
};

class FaultInjector final : public MeasurementSink {
 public:
  static constexpr int kMaxFaults = 16;
  // faults: at most kMaxFaults (std::invalid_argument beyond); out: not owned.
  FaultInjector(const Fault* faults, int count, std::uint64_t seed, MeasurementSink* out);
  FaultInjector(const FaultInjector&) = delete;
  FaultInjector& operator=(const FaultInjector&) = delete;

  void on_imu(const ImuSample& sample) override;
  void on_stereo(const StereoFrame& frame) override;
  // A sample still held by imu-swap goes on.
  void flush();
  const FaultCounters& counters() const { return counters_; }

 private:
  bool active(const Fault& f, std::int64_t t_ns) const;
  bool any_active(FaultKind kind, std::int64_t t_ns) const;
  std::int64_t restamp(std::int64_t t_ns);
  void remember(const StereoFrame& frame);
  void emit_frame(const StereoFrame& frame);

  Fault faults_[kMaxFaults];
  int n_ = 0;
  MeasurementSink* out_;
  std::int64_t t0_ns_ = -1;
  std::mt19937_64 rng_;
  bool have_swap_ = false;
  ImuSample swap_held_;
  // frame-freeze: the last pair before the fault; blackout: black pixels.
  std::unique_ptr<std::uint8_t[]> frozen_[2], black_;
  std::size_t buffer_bytes_ = 0;
  ImageView frozen_view_[2];
  FaultCounters counters_;
};

}  // namespace ums::hal
