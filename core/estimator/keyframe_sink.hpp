#pragma once
// The outlet through which every keyframe that leaves the window (marginalized as the oldest)
// reaches whatever keeps a map of them (the loop-closure keyframe database). Its pose and points
// are in the odometry frame at the moment it left; the record is the Marginalizer's, valid only
// during the call (copy what you keep). Called on the frame path: a sink must not block.

#include <cstdint>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "core/common/capacity.hpp"
#include "core/common/fixed_vector.hpp"
#include "core/estimator/frame_id.hpp"

namespace ums {

struct KeyframeObservation {
  std::uint32_t landmark_id = 0;   // the front end's feature id
  bool has_left = false;
  bool has_right = false;
  bool stereo = false;             // a 3D landmark (seen by both cameras in some window frame)
  bool has_point = false;          // p_odom is known (depth estimated)
  Eigen::Vector3f bearing_left = Eigen::Vector3f::UnitZ();   // unit, cam0
  Eigen::Vector3f bearing_right = Eigen::Vector3f::UnitZ();  // unit, cam1
  Eigen::Vector3d p_odom = Eigen::Vector3d::Zero();          // m, landmark in the odometry frame
};

struct MarginalizedKeyframe {
  FrameId id = kNoFrame;
  std::int64_t t_ns = 0;                                     // IMU clock
  // Changes whenever the odometry frame restarts or is re-levelled (a reset, entering VIO):
  // poses and points of keyframes with different epochs are in different frames.
  std::uint32_t odometry_epoch = 0;
  bool gravity_aligned = false;  // the odometry frame is levelled to gravity (VIO), z up
  Eigen::Isometry3d T_odom_b = Eigen::Isometry3d::Identity();
  FixedVector<KeyframeObservation, capacity::kMaxLandmarks> observations;
};

class KeyframeSink {
 public:
  virtual ~KeyframeSink() = default;
  virtual void on_keyframe(const MarginalizedKeyframe& keyframe) = 0;
};

}  // namespace ums
