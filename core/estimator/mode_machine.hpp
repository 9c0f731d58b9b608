#pragma once
// The estimator's modes (paper Sec. III-B) and the one function that changes them. The parts
// that initialize or track report what happened (a ModeEvent); only transition() decides the
// mode that follows, so the machine can be read, and tested, in one place.
//
//   IMU_ONLY --visual init--> VO --alignment--> VIO
//   IMU_ONLY, VO --standstill--> VIO
//   VO --vision lost--> IMU_ONLY          VIO, VISION_LOST --divergence--> IMU_ONLY
//   VIO --no tracked landmarks--> VISION_LOST --tracking back--> VIO
//
// VISION_LOST keeps VIO's window, gravity, velocity and biases: the pose is the IMU's alone (the
// images show nothing to track: dark, covered, blacked out) and is reported as such, so that a
// consumer does not fly it as VIO. Nothing has to be initialized again when the images return.

#include <cstdint>

namespace ums {

enum class EstimatorMode : std::uint8_t { kImuOnly = 0, kVo = 1, kVio = 2, kVisionLost = 3 };
inline constexpr int kEstimatorModes = 4;

constexpr const char* to_string(EstimatorMode m) {
  switch (m) {
    case EstimatorMode::kImuOnly: return "IMU_ONLY";
    case EstimatorMode::kVo: return "VO";
    case EstimatorMode::kVio: return "VIO";
    case EstimatorMode::kVisionLost: return "VISION_LOST";
  }
  return "unknown";
}

enum class ModeEvent : std::uint8_t {
  kNone = 0,
  kVisualInit,    // stereo visual initialization succeeded (case 2 begins)
  kStandstill,    // initialized at rest: gravity, zero velocity and gyro bias from the IMU
  kAlignment,     // the visual-IMU alignment was accepted (case 3)
  kVisionLost,    // tracking failed in VO
  kDivergence,    // non-finite state or impossible speed in VIO
  kTracksLost,    // VIO: too few tracked landmarks for long enough
  kTracksBack,    // VISION_LOST: enough tracked landmarks again
};

struct ModeTransition {
  EstimatorMode to = EstimatorMode::kImuOnly;
  const char* reason = "";  // static string, logged in stats.json modes
  bool changed = false;
};

// The mode after `event` in mode `from`; events that do not apply in `from` change nothing.
ModeTransition transition(EstimatorMode from, ModeEvent event);

}  // namespace ums
