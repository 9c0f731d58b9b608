#include "core/estimator/mode_machine.hpp"

#include <catch2/catch.hpp>
#include <string>

using ums::EstimatorMode;
using ums::ModeEvent;

TEST_CASE("transition: the paper's mode machine, and nothing else", "[estimator][mode]") {
  const EstimatorMode kImu = EstimatorMode::kImuOnly, kVo = EstimatorMode::kVo, kVio = EstimatorMode::kVio,
                      kLost = EstimatorMode::kVisionLost;
  struct Row {
    EstimatorMode from;
    ModeEvent event;
    EstimatorMode to;
    const char* reason;  // nullptr: no change
  };
  const Row rows[] = {
      {kImu, ModeEvent::kVisualInit, kVo, "visual init"},
      {kImu, ModeEvent::kStandstill, kVio, "standstill"},
      {kVo, ModeEvent::kStandstill, kVio, "standstill"},
      {kVo, ModeEvent::kAlignment, kVio, "visual-imu alignment"},
      {kVo, ModeEvent::kVisionLost, kImu, "vision lost in VO"},
      {kVio, ModeEvent::kDivergence, kImu, "divergence"},
      {kVio, ModeEvent::kTracksLost, kLost, "vision lost in VIO"},
      {kLost, ModeEvent::kTracksBack, kVio, "vision back"},
      {kLost, ModeEvent::kDivergence, kImu, "divergence"},
      // Events that do not apply change nothing.
      {kImu, ModeEvent::kAlignment, kImu, nullptr},
      {kImu, ModeEvent::kVisionLost, kImu, nullptr},
      {kImu, ModeEvent::kDivergence, kImu, nullptr},
      {kVo, ModeEvent::kVisualInit, kVo, nullptr},
      {kVo, ModeEvent::kDivergence, kVo, nullptr},
      {kVio, ModeEvent::kVisualInit, kVio, nullptr},
      {kVio, ModeEvent::kStandstill, kVio, nullptr},
      {kVio, ModeEvent::kAlignment, kVio, nullptr},
      {kVio, ModeEvent::kVisionLost, kVio, nullptr},
      {kVio, ModeEvent::kTracksBack, kVio, nullptr},
      {kImu, ModeEvent::kTracksLost, kImu, nullptr},
      {kImu, ModeEvent::kTracksBack, kImu, nullptr},
      {kVo, ModeEvent::kTracksLost, kVo, nullptr},
      {kVo, ModeEvent::kTracksBack, kVo, nullptr},
      // VISION_LOST keeps VIO's window: no initialization event applies, and a standstill does
      // not re-level it.
      {kLost, ModeEvent::kVisualInit, kLost, nullptr},
      {kLost, ModeEvent::kStandstill, kLost, nullptr},
      {kLost, ModeEvent::kAlignment, kLost, nullptr},
      {kLost, ModeEvent::kVisionLost, kLost, nullptr},
      {kLost, ModeEvent::kTracksLost, kLost, nullptr},
      {kLost, ModeEvent::kNone, kLost, nullptr},
      {kImu, ModeEvent::kNone, kImu, nullptr},
      {kVo, ModeEvent::kNone, kVo, nullptr},
      {kVio, ModeEvent::kNone, kVio, nullptr},
  };
  for (const Row& r : rows) {
    const ums::ModeTransition t = ums::transition(r.from, r.event);
    INFO(ums::to_string(r.from) << " event " << static_cast<int>(r.event));
    CHECK(t.to == r.to);
    CHECK(t.changed == (r.reason != nullptr));
    if (r.reason != nullptr) CHECK(std::string(t.reason) == r.reason);
  }
}
