#pragma once
// Motion blur sampling for the photo style: a frame integrates light over the exposure time,
// centred on the frame stamp; the renderer averages n sub-exposures at the poses
//   t_j = t - E/2 + (j + 1/2) E / n,  j = 0 .. n-1.
// n follows the image motion during the exposure so that static frames cost one render and fast
// ones stay bounded: blur_px = f (|Log(R_0^T R_1)| + |p_1 - p_0| / near_depth_m) over the
// exposure, n = clamp(ceil(blur_px / max_step_px), 1, max_sub_exposures).

#include <cstdint>
#include <string>

#include <Eigen/Geometry>

namespace ums::sim {

struct ExposureOptions {
  double exposure_ms = 4.0;      // ms; 0: no blur (one sample at the stamp)
  double max_step_px = 1.0;      // px of image motion between neighbouring sub-exposures
  int max_sub_exposures = 4;     // cost bound (<= kMaxSubExposures of photo_renderer.hpp)
  double near_depth_m = 1.5;     // m, depth for the translation part of the image motion
  bool validate(std::string* error) const;
};

// Image motion in px between the body poses at the start and end of the exposure.
double exposure_blur_px(const Eigen::Isometry3d& T_w_b_begin, const Eigen::Isometry3d& T_w_b_end, double focal_px,
                        double near_depth_m);

int sub_exposure_count(double blur_px, const ExposureOptions& options);

// Stamp of sub-exposure j of n for a frame at t_ns.
std::int64_t sub_exposure_time_ns(std::int64_t t_ns, double exposure_ms, int n, int j);

}  // namespace ums::sim
