#pragma once
// Locates a window frame by PnP on bearings (RANSAC + Gauss-Newton, geometry.hpp) against the
// landmarks that have depth and are hosted in another frame; PnP's outliers are marked. Used by
// the visual initialization (IMU_ONLY) and by tracking in VO. Scratch buffers allocated once.

#include <cstdint>
#include <memory>

#include <Eigen/Geometry>

#include "core/estimator/geometry.hpp"

namespace ums {

class Window;
class LandmarkMap;

class PnpLocator {
 public:
  PnpLocator(int min_inliers, double inlier_rad);
  // Writes the pose of window slot `slot` on success (prior: the first hypothesis).
  bool locate(Window& window, LandmarkMap& landmarks, int slot, const Eigen::Isometry3d& prior);

 private:
  int collect(const Window& window, const LandmarkMap& landmarks, int slot);

  int min_inliers_;
  double inlier_rad_;
  std::unique_ptr<PnpMatch[]> matches_;
  std::unique_ptr<std::uint8_t[]> mask_;
  std::unique_ptr<std::int16_t[]> landmark_;  // pool index of each match
};

}  // namespace ums
