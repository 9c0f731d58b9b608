#include "core/estimator/mode_machine.hpp"

namespace ums {

ModeTransition transition(EstimatorMode from, ModeEvent event) {
  ModeTransition t;
  t.to = from;
  switch (event) {
    case ModeEvent::kNone: break;
    case ModeEvent::kVisualInit:
      if (from == EstimatorMode::kImuOnly) t = {EstimatorMode::kVo, "visual init", true};
      break;
    case ModeEvent::kStandstill:
      if (from == EstimatorMode::kImuOnly || from == EstimatorMode::kVo) t = {EstimatorMode::kVio, "standstill", true};
      break;
    case ModeEvent::kAlignment:
      if (from == EstimatorMode::kVo) t = {EstimatorMode::kVio, "visual-imu alignment", true};
      break;
    case ModeEvent::kVisionLost:
      if (from == EstimatorMode::kVo) t = {EstimatorMode::kImuOnly, "vision lost in VO", true};
      break;
    case ModeEvent::kDivergence:
      if (from == EstimatorMode::kVio || from == EstimatorMode::kVisionLost)
        t = {EstimatorMode::kImuOnly, "divergence", true};
      break;
    case ModeEvent::kTracksLost:
      if (from == EstimatorMode::kVio) t = {EstimatorMode::kVisionLost, "vision lost in VIO", true};
      break;
    case ModeEvent::kTracksBack:
      if (from == EstimatorMode::kVisionLost) t = {EstimatorMode::kVio, "vision back", true};
      break;
  }
  return t;
}

}  // namespace ums
