#pragma once
// Keyframe decision (paper Sec. III-A.1): a frame becomes a keyframe when any of
//  1. the time since the last keyframe exceeds max_interval_s;
//  2. the average parallax of the features shared with the last keyframe exceeds
//     min_parallax_px (measured in the undistorted z = 1 plane and scaled by a virtual focal
//     length, as VINS-Fusion does, so the threshold does not depend on the camera);
//  3. the number of 3D features plus 2D features whose depth is initialized from 3D features
//     falls below min_depth_features. Only the estimator knows which 2D features have a depth,
//     so the caller passes that count.
// A frame sharing fewer than min_shared_features with the last keyframe also becomes one (no
// parallax can be measured). The last keyframe's observations are kept in fixed storage,
// sorted by id for binary search.

#include <cstdint>

#include <Eigen/Core>

#include "core/common/capacity.hpp"
#include "core/frontend/frame_features.hpp"

namespace ums {

struct KeyframeOptions {
  double max_interval_s = 0.5;     // s, a keyframe at least this often
  float min_parallax_px = 10.0f;   // px at focal_px (VINS-Fusion keyframe_parallax = 10)
  float focal_px = 460.0f;         // px, virtual focal length of the parallax measure
  int min_depth_features = 40;     // features, 3D + 2D-with-depth below this -> keyframe
  int min_shared_features = 20;    // features shared with the last keyframe below this -> keyframe

  void validate() const;  // throws std::invalid_argument naming the field and value
};

enum KeyframeReason : std::uint8_t {
  kKeyframeNone = 0,
  kKeyframeFirst = 1 << 0,
  kKeyframeInterval = 1 << 1,
  kKeyframeParallax = 1 << 2,
  kKeyframeFewDepthFeatures = 1 << 3,
  kKeyframeFewShared = 1 << 4,
};

struct KeyframeDecision {
  bool is_keyframe = false;
  std::uint8_t reasons = kKeyframeNone;  // KeyframeReason bits
  float mean_parallax_px = 0.0f;         // px at focal_px, over shared features
  int shared_features = 0;               // features also seen in the last keyframe
  double since_last_s = 0.0;             // s
};

class KeyframeSelector {
 public:
  explicit KeyframeSelector(const KeyframeOptions& options);

  // Decides for this frame; when it is a keyframe, it becomes the reference for later frames.
  // n_2d_with_depth: 2D features whose depth the estimator has initialized from 3D features.
  // Allocates nothing.
  KeyframeDecision update(const FrameFeatures& frame, int n_2d_with_depth);

  void reset() { has_keyframe_ = false; }
  bool has_keyframe() const { return has_keyframe_; }

 private:
  struct Entry {
    std::uint32_t id;
    FeatureClass cls;
    Eigen::Vector2f xy;  // normalized point in the camera that observes the feature (left if any)
  };
  static Eigen::Vector2f reference_xy(const FeatureObservation& o) { return o.has_left() ? o.xy_left : o.xy_right; }

  KeyframeOptions options_;
  bool has_keyframe_ = false;
  std::int64_t last_t_ns_ = 0;
  Entry entries_[capacity::kMaxFeaturesPerCamera];
  std::size_t n_entries_ = 0;
};

}  // namespace ums
