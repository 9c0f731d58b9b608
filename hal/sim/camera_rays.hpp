#pragma once
// The per-pixel rays of one simulated camera, computed once at start-up: a unit bearing per
// pixel from core/camera's unproject (so a rendered image follows the configured pinhole
// radtan / equidistant model exactly) and the pixel's angular footprint (the angle to the
// right-hand neighbour's ray: metres of footprint per metre of range), which picks the mip level.

#include <vector>

#include <Eigen/Core>

#include "core/common/calibration.hpp"

namespace ums::sim {

struct CameraRays {
  int width = 0, height = 0;                 // px
  std::vector<Eigen::Vector3f> bearing;      // unit ray per pixel, camera frame, rows packed
  std::vector<float> footprint;              // rad per pixel (>= 1e-5)
};

// Throws std::runtime_error naming the camera on an invalid calibration.
CameraRays make_camera_rays(const CameraCalibration& calibration, int camera_index);

}  // namespace ums::sim
