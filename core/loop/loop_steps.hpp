#pragma once
// The loop closer's per-keyframe work in its two steps, so that a thread can run the second one
// (board/host/loop_worker) and be tested with steps of its own.

#include <cstdint>

#include <Eigen/Geometry>

#include "core/common/capacity.hpp"
#include "core/common/fixed_vector.hpp"
#include "core/estimator/keyframe_sink.hpp"
#include "core/estimator/relocation.hpp"
#include "core/loop/keyframe_database.hpp"

namespace ums::loop {

// A keyframe leaving the window as the loop closer keeps it: its pose and its 3D features with
// their descriptors (prepare()'s output, add_keyframe()'s input).
struct LoopKeyframe {
  FrameId id = kNoFrame;
  std::int64_t t_ns = 0;
  std::uint32_t odometry_epoch = 0;
  bool gravity_aligned = false;
  bool described = false;  // its image was described (else it has no features)
  Eigen::Isometry3d T_odom_b = Eigen::Isometry3d::Identity();
  FixedVector<LoopFeature, capacity::kMaxLoopFeaturesPerKeyframe> features;
  // Per feature, the window's landmark id (a relocation request's key: only the newest keyframe's
  // are kept, not the database's 2000 x 300).
  std::uint32_t landmark_id[capacity::kMaxLoopFeaturesPerKeyframe] = {};
};

// Where the current odometry frame sits in the map (what a MapFrameSource answers from).
struct MapPlacement {
  bool started = false;          // a levelled keyframe has arrived
  std::uint32_t epoch = 0;       // the odometry epoch of the current session
  bool placed = false;           // the current session is placed in the map
  Eigen::Isometry3d T_map_odom = Eigen::Isometry3d::Identity();
  std::uint32_t corrections = 0;
  // false while the odometry frame of that epoch is not placed in the map.
  bool map_from_odometry(std::uint32_t odometry_epoch, Eigen::Isometry3d* T_map_odom_out) const {
    if (!started || odometry_epoch != epoch || !placed) return false;
    *T_map_odom_out = T_map_odom;
    return true;
  }
};

// The tightly coupled relocation link (take_relocation, on_relocated) runs on the thread of
// add_keyframe as well: a loop's request is made there, its result refines the loop there.
class LoopSteps : public RelocationLink {
 public:
  // Cheap: the keyframe's described 3D features, on the thread that receives its image.
  virtual void prepare(const MarginalizedKeyframe& keyframe, LoopKeyframe* out) const = 0;
  // Costly: keep, query, verify, close (any thread, one keyframe at a time, in order).
  virtual void add_keyframe(const LoopKeyframe& keyframe) = 0;
  // After add_keyframe, on its thread.
  virtual MapPlacement placement() const = 0;
};

}  // namespace ums::loop
