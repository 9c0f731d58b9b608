#pragma once
// A copy of everything a solve moves (every slot's pose and speed-bias, the extrinsic blocks, the
// landmarks' depths), to try a solve and take it back: the two-stage test, the alignment's two
// loosely coupled BAs, a failed alignment.

#include "core/common/state_layout.hpp"
#include "core/estimator/landmark_map.hpp"
#include "core/estimator/window.hpp"

namespace ums {

struct WindowBackup {
  double pose[Window::kSlots][state::kPoseSize];
  double sb[Window::kSlots][state::kSbSize];
  double extrinsic[2][state::kPoseSize];
  double td_s = 0.0;
  double gyro_scale[3] = {0.0, 0.0, 0.0};
  LandmarkMap::DepthBackup depths;
};

void save_window(const Window& window, const LandmarkMap& landmarks, WindowBackup* b);
void restore_window(const WindowBackup& b, Window* window, LandmarkMap* landmarks);

}  // namespace ums
