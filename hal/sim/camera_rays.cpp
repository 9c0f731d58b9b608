#include "hal/sim/camera_rays.hpp"

#include <algorithm>
#include <stdexcept>
#include <string>

#include "core/camera/camera.hpp"

namespace ums::sim {

CameraRays make_camera_rays(const CameraCalibration& cc, int camera_index) {
  if (cc.width <= 0 || cc.height <= 0 || !(cc.fx > 0.0) || !(cc.fy > 0.0)) {
    throw std::runtime_error("StereoRenderer: camera " + std::to_string(camera_index) + " calibration invalid");
  }
  const auto cam = CameraT<double>::from_calibration(cc);
  CameraRays rays;
  rays.width = cc.width;
  rays.height = cc.height;
  rays.bearing.resize(static_cast<std::size_t>(cc.width) * cc.height);
  rays.footprint.resize(rays.bearing.size());
  for (int v = 0; v < cc.height; ++v) {
    // One unproject per pixel plus one past the row end; the footprint is the angle to the
    // right-hand neighbour's ray.
    Eigen::Vector3d next;
    if (!cam.unproject(Eigen::Vector2d(0.0, v), &next)) next = Eigen::Vector3d::UnitZ();
    for (int u = 0; u < cc.width; ++u) {
      const Eigen::Vector3d b = next;
      if (!cam.unproject(Eigen::Vector2d(u + 1.0, v), &next)) next = b;
      const std::size_t i = static_cast<std::size_t>(v) * cc.width + u;
      rays.bearing[i] = b.cast<float>();
      rays.footprint[i] = static_cast<float>(std::max(1e-5, (next - b).norm()));
    }
  }
  return rays;
}

}  // namespace ums::sim
