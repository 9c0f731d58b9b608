#include "hal/sim/exposure.hpp"

#include <algorithm>
#include <cmath>
#include <string>

#include "core/math/so3.hpp"

namespace ums::sim {

bool ExposureOptions::validate(std::string* error) const {
  if (!(exposure_ms >= 0.0 && exposure_ms <= 40.0) || !(max_step_px > 0.0) || max_sub_exposures < 1 ||
      max_sub_exposures > 8 || !(near_depth_m > 0.0)) {
    if (error) {
      *error = "ExposureOptions: exposure_ms in [0, 40], max_step_px > 0, max_sub_exposures in [1, 8], "
               "near_depth_m > 0 required (exposure_ms " + std::to_string(exposure_ms) + ")";
    }
    return false;
  }
  return true;
}

double exposure_blur_px(const Eigen::Isometry3d& T0, const Eigen::Isometry3d& T1, double focal_px, double near_depth_m) {
  const double angle_rad = so3::angle(Eigen::Matrix3d(T0.linear().transpose() * T1.linear()));
  const double shift_m = (T1.translation() - T0.translation()).norm();
  return focal_px * (angle_rad + shift_m / near_depth_m);
}

int sub_exposure_count(double blur_px, const ExposureOptions& o) {
  if (!(o.exposure_ms > 0.0)) return 1;
  const int n = static_cast<int>(std::ceil(blur_px / o.max_step_px));
  return std::clamp(n, 1, o.max_sub_exposures);
}

std::int64_t sub_exposure_time_ns(std::int64_t t_ns, double exposure_ms, int n, int j) {
  const double offset_ms = -0.5 * exposure_ms + (static_cast<double>(j) + 0.5) * exposure_ms / static_cast<double>(n);
  return t_ns + static_cast<std::int64_t>(std::llround(offset_ms * 1e6));
}

}  // namespace ums::sim
