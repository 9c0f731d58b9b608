#pragma once
// Tightly coupled relocation (the paper's Sec. III-C, r_C(l,v)): when loop closure accepts a loop
// for a keyframe q that just left the window, the loop keyframe v's observations of the landmarks
// it shares with q enter the window's next solve as robust bearing residuals. v's pose is a free
// parameter block there (VINS-Mono's relocation frame), started where the loop's measurement puts
// it. Both ways, as the loop verifier: the window's landmark seen by v, and v's stereo point seen
// by the window frames that track the landmark (loop_point_residual.hpp). The residuals tie v to
// the window's own landmark estimates and observations, and move no window pose through a prior
// (the odometry stays continuous). The refined pose of v relative to q goes back to the pose graph as the loop's
// measurement.
//
// The link between the loop closer and the window runs on the frame thread: take a request
// before a solve, hand the result back after it.

#include <cstdint>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "core/common/capacity.hpp"
#include "core/common/fixed_vector.hpp"
#include "core/estimator/frame_id.hpp"

namespace ums {

struct RelocationMatch {
  std::uint32_t landmark_id = 0;                           // the front end's feature id (q's landmark)
  Eigen::Vector3f bearing_c0 = Eigen::Vector3f::UnitZ();  // unit, the loop keyframe's left camera
  Eigen::Vector3f p_loop_b = Eigen::Vector3f::Zero();     // m, its stereo point in the loop keyframe's body
};

struct RelocationRequest {
  FrameId query = kNoFrame;   // q, out of the window
  FrameId loop = kNoFrame;    // v, the loop keyframe
  std::uint32_t odometry_epoch = 0;                              // q's odometry frame
  Eigen::Isometry3d T_odom_q = Eigen::Isometry3d::Identity();    // q as it left the window
  Eigen::Isometry3d T_q_loop = Eigen::Isometry3d::Identity();    // the loop's measurement, bodies
  FixedVector<RelocationMatch, capacity::kMaxLoopFeaturesPerKeyframe> matches;
};

struct RelocationResult {
  FrameId query = kNoFrame, loop = kNoFrame;
  int residuals = 0;  // relocation residuals in the solve (landmarks still in the window)
  int inliers = 0;    // of those, within the estimator's outlier bound after it
  Eigen::Isometry3d T_loop_query = Eigen::Isometry3d::Identity();  // refined, bodies
};

class RelocationLink {
 public:
  virtual ~RelocationLink() = default;
  // The newest request not yet taken (older ones are superseded); false when there is none.
  virtual bool take_relocation(RelocationRequest* out) = 0;
  // After the solve that used the request (also when it could not: residuals 0).
  virtual void on_relocated(const RelocationResult& result) = 0;
};

}  // namespace ums
