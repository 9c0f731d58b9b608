#pragma once
// The flight as the final map has it (issue 17 item 6; docs/loop-closure.md "Two outputs").
//
// While flying, a frame can only be placed with the map frame known at its time (MapFramePoses:
// the newest keyframe's correction; trajectory_map_live.tum and the MAVLink output). After the
// run every keyframe of the run has its final, pose-graph-optimized map pose, and each one gives
// a correction C_k = T_map_k * T_odom_k^-1: a yaw and a translation, both frames being levelled
// to gravity. A frame takes the corrections of the two keyframes of its odometry frame (epoch)
// around it, interpolated in time (yaw and translation, linearly), or the nearest one's before
// the first and after the last; a frame whose odometry frame has no placed keyframe has no map
// pose. So a loop corrects the flight before it too, as the map's keyframes are corrected, which
// is what a map of the flight (and a comparison with peers' pose-graph outputs) wants.
// T_odom_k is the keyframe's marginalized pose. (Taking instead the frame output's pose at the
// keyframe's time, so that a frame at a keyframe's time gets exactly the keyframe's map pose,
// measured the same: whole V102, ATE 4.5 mm both.) Built at shut-down: allocates.

#include <cstdint>
#include <vector>

#include <Eigen/Geometry>

#include "core/loop/keyframe_database.hpp"

namespace ums::loop {

class FinalMapPoses {
 public:
  // The database's placed keyframes of this run (not those read from a map file).
  explicit FinalMapPoses(const KeyframeDatabase& db);

  // A frame's map pose; false when its odometry frame has no placed keyframe.
  bool map_pose(std::int64_t t_ns, std::uint32_t odometry_epoch, const Eigen::Isometry3d& T_odom_b,
                Eigen::Isometry3d* T_map_b) const;
  std::size_t keyframes() const { return keyframes_.size(); }

 private:
  struct Keyframe {  // its correction C_k
    std::int64_t t_ns;
    std::uint32_t epoch;
    double yaw_rad;
    Eigen::Vector3d p_m;
  };
  std::vector<Keyframe> keyframes_;  // time order
};

}  // namespace ums::loop
