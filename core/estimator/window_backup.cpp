#include "core/estimator/window_backup.hpp"

#include <algorithm>

namespace ums {

void save_window(const Window& window, const LandmarkMap& landmarks, WindowBackup* b) {
  for (int s = 0; s < Window::kSlots; ++s) {
    const WindowFrame& f = window.slot(s);
    std::copy(f.pose, f.pose + state::kPoseSize, b->pose[s]);
    std::copy(f.sb, f.sb + state::kSbSize, b->sb[s]);
  }
  for (int c = 0; c < 2; ++c) {
    const double* x = window.extrinsics().block(c);
    std::copy(x, x + state::kPoseSize, b->extrinsic[c]);
  }
  b->td_s = window.time_offset().value_s();
  std::copy(window.gyro_scale().block(), window.gyro_scale().block() + 3, b->gyro_scale);
  landmarks.save_depths(&b->depths);
}

void restore_window(const WindowBackup& b, Window* window, LandmarkMap* landmarks) {
  for (int s = 0; s < Window::kSlots; ++s) {
    WindowFrame& f = window->slot(s);
    std::copy(b.pose[s], b.pose[s] + state::kPoseSize, f.pose);
    std::copy(b.sb[s], b.sb[s] + state::kSbSize, f.sb);
  }
  for (int c = 0; c < 2; ++c) std::copy(b.extrinsic[c], b.extrinsic[c] + state::kPoseSize, window->extrinsics().block(c));
  window->extrinsics().sync();
  window->time_offset().block()[0] = b.td_s;
  std::copy(b.gyro_scale, b.gyro_scale + 3, window->gyro_scale().block());
  landmarks->restore_depths(b.depths);
}

}  // namespace ums
