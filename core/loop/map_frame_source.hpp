#pragma once
// Where the map frame comes from (the LoopCloser): T_map_odom of an odometry epoch, and a count
// that grows with every change of it. An interface so that its consumers (MapFramePoses) can be
// tested alone.

#include <cstdint>

#include <Eigen/Geometry>

namespace ums::loop {

class MapFrameSource {
 public:
  virtual ~MapFrameSource() = default;
  // false while the odometry frame of that epoch is not placed in the map.
  virtual bool map_from_odometry(std::uint32_t odometry_epoch, Eigen::Isometry3d* T_map_odom) const = 0;
  // Incremented by every change of T_map_odom.
  virtual std::uint32_t corrections() const = 0;
};

}  // namespace ums::loop
