#pragma once
// The loop-closure keyframe database: every keyframe that left the window, in order, with what
// place recognition and verification need (its 3D features' descriptors, their points in the
// keyframe's body frame and their left bearings, its bag of words) and what the pose graph needs
// (its odometry pose, its session, its loops). A fixed pool of kMaxKeyframes records allocated
// at construction; records are linked in time order so that one can be dropped from the middle.
//
// When the pool is full, the policy is spatial decimation (docs/loop-closure.md): the keyframe,
// among those without a loop and older than the protected recent ones, that is closest in
// position and yaw to its predecessor is dropped; its neighbours' odometry edge then spans it.

#include <cstdint>
#include <memory>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "core/common/capacity.hpp"
#include "core/common/fixed_vector.hpp"
#include "core/common/status.hpp"
#include "core/estimator/frame_id.hpp"
#include "core/loop/bow_vector.hpp"
#include "core/loop/brief.hpp"

namespace ums::loop {

struct LoopFeature {
  Descriptor descriptor{};
  Eigen::Vector3f p_b = Eigen::Vector3f::Zero();       // m, the point in the keyframe's body frame
  Eigen::Vector3f bearing_c0 = Eigen::Vector3f::UnitZ();  // unit, the left camera's observation
};

// KeyframeRecord::odometry_epoch of a keyframe read from a map file (no odometry of this run).
inline constexpr std::uint32_t kMapEpoch = 0xFFFFFFFFu;

struct KeyframeRecord {
  FrameId id = kNoFrame;
  std::int64_t t_ns = 0;
  std::uint32_t session = 0;     // odometry frames differ across sessions (estimator resets)
  // The estimator's odometry epoch of this run's keyframes; kMapEpoch for those read from a map.
  std::uint32_t odometry_epoch = kMapEpoch;
  bool placed = false;           // its session is placed in the map (T_map_b is meaningful)
  Eigen::Isometry3d T_odom_b = Eigen::Isometry3d::Identity();  // as the odometry had it
  Eigen::Isometry3d T_map_b = Eigen::Isometry3d::Identity();   // after the last pose-graph solve
  double path_m = 0.0;           // m, distance flown since the session's first keyframe
  std::uint16_t loops = 0;       // accepted loops this keyframe is an end of
  bool indexed = false;          // in the place-recognition index
  FixedVector<LoopFeature, capacity::kMaxLoopFeaturesPerKeyframe> features;
  BowVector bow;
  std::int32_t prev = -1, next = -1;  // time order (slots)
};

class KeyframeDatabase {
 public:
  // protected_recent: the newest keyframes decimation never drops.
  explicit KeyframeDatabase(int protected_recent);
  KeyframeDatabase(const KeyframeDatabase&) = delete;
  KeyframeDatabase& operator=(const KeyframeDatabase&) = delete;

  // A free record for the next keyframe (kFull when full: call decimate() first). The record is
  // reset; fill it, then commit() links it as the newest.
  Status reserve(std::uint32_t* slot);
  void commit(std::uint32_t slot);
  // Drops one keyframe by the decimation policy; returns its slot (so the caller can take it
  // out of the index first through on_drop) or -1 when nothing may be dropped.
  std::int32_t pick_for_decimation() const;
  void remove(std::uint32_t slot);

  KeyframeRecord& at(std::uint32_t slot) { return records_[slot]; }
  const KeyframeRecord& at(std::uint32_t slot) const { return records_[slot]; }
  bool full() const { return size_ == capacity::kMaxKeyframes; }
  std::size_t size() const { return size_; }
  std::int32_t oldest() const { return head_; }
  std::int32_t newest() const { return tail_; }
  std::size_t footprint_bytes() const;

 private:
  int protected_recent_;
  std::unique_ptr<KeyframeRecord[]> records_;
  std::unique_ptr<std::uint32_t[]> free_;  // stack of free slots
  std::size_t n_free_ = 0;
  std::size_t size_ = 0;
  std::int32_t head_ = -1, tail_ = -1;
};

}  // namespace ums::loop
