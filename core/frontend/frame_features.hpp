#pragma once
// What the front end hands to the estimator for one stereo frame: every live feature with its
// class, id, track length and both pixel and undistorted coordinates, plus per-frame counts.
//
// Classes (the paper's united features, Sec. III-A.1):
//   k3D      seen in left and right (stereo match passed the calibrated epipolar check):
//            the left and right fields are both valid;
//   k2DLeft  seen in the left camera only: right fields are NaN;
//   k2DRight seen in the right camera only (detected where no left feature covers the right
//            image): left fields are NaN.
// A left feature keeps its id when it switches between k3D and k2DLeft from frame to frame.

#include <cstdint>

#include <Eigen/Core>

#include "core/common/capacity.hpp"
#include "core/common/fixed_vector.hpp"

namespace ums {

enum class FeatureClass : std::uint8_t { k3D = 0, k2DLeft = 1, k2DRight = 2 };

constexpr const char* to_string(FeatureClass c) {
  switch (c) {
    case FeatureClass::k3D: return "3d";
    case FeatureClass::k2DLeft: return "2d_left";
    case FeatureClass::k2DRight: return "2d_right";
  }
  return "unknown";
}

struct FeatureObservation {
  std::uint32_t id = 0;             // unique over the run (monotonic), shared by both cameras
  FeatureClass cls = FeatureClass::k2DLeft;
  std::uint32_t track_length = 0;   // frames in which this id was observed, this one included
  Eigen::Vector2f uv_left_px = Eigen::Vector2f::Zero();       // distorted pixel in cam0 (NaN for k2DRight)
  Eigen::Vector2f uv_right_px = Eigen::Vector2f::Zero();      // distorted pixel in cam1 (NaN for k2DLeft)
  Eigen::Vector2f xy_left = Eigen::Vector2f::Zero();          // undistorted normalized point (z = 1 plane) in cam0
  Eigen::Vector2f xy_right = Eigen::Vector2f::Zero();         // undistorted normalized point (z = 1 plane) in cam1
  Eigen::Vector3f bearing_left = Eigen::Vector3f::Zero();     // unit vector in cam0
  Eigen::Vector3f bearing_right = Eigen::Vector3f::Zero();    // unit vector in cam1

  bool has_left() const { return cls != FeatureClass::k2DRight; }
  bool has_right() const { return cls != FeatureClass::k2DLeft; }
};

// Per-frame diagnostics (counts of features, in the order the pipeline drops them).
struct FrontendFrameStats {
  int tracked_left = 0;          // left tracks that survived KLT + forward-backward
  int tracked_right = 0;         // 2D-right tracks that survived KLT + forward-backward
  int lost_klt = 0;              // KLT failed (untextured, left the image, residual too large)
  int lost_fb = 0;               // forward-backward disagreement above fb_max_px
  int lost_ransac = 0;           // epipolar RANSAC outliers between consecutive frames
  int lost_crowding = 0;         // closer than min_distance to a longer track
  int retried_3d = 0;            // 3D tracks that needed the 4-level retry
  int retried_3d_ok = 0;         // ... and succeeded with it
  int new_left = 0;              // detections in the left image
  int new_right = 0;             // detections in uncovered right-image regions
  int stereo_attempts = 0;       // left features tried in the right image
  int stereo_confirmations = 0;  // right->left KLT confirmations run (FrontendOptions::stereo_confirm_tracked)
  int stereo_rejected_klt = 0;   // left->right KLT or right->left confirmation failed
  int stereo_rejected_epipolar = 0;  // match farther than stereo_epipolar_max_px from its epipolar line
  float stereo_epipolar_rms_px = 0.0f;  // px, RMS distance of accepted 3D matches to their epipolar line

  // Wall time of the sub-stages of this frame's Frontend::process (ms, steady clock; all 0 when
  // FrontendOptions::measure_stages is false or process() rejected the frame). Consecutive laps
  // of one clock: they never overlap, and their sum is at most the time of the call. Not charged
  // to any: the input checks, the track-length increments and copying the tracks into
  // FrameFeatures (a few microseconds).
  float pyramid_ms = 0.0f;  // both pyramids (left, and right when the right image is valid)
  float detect_ms = 0.0f;   // new corners: crowding of the left tracks + left detection, and the right-image mask + 2D-right detection
  float track_ms = 0.0f;    // temporal KLT of left and 2D-right tracks incl. their forward-backward checks and the IMU prediction
  float stereo_ms = 0.0f;   // left->right matching: KLT into the right image, right->left confirmation, epipolar check
  float ransac_ms = 0.0f;   // temporal epipolar RANSAC of both cameras (incl. compacting the inliers)

  // Sum of the five sub-stages (ms).
  float stages_ms() const { return pyramid_ms + detect_ms + track_ms + stereo_ms + ransac_ms; }
};

struct FrameFeatures {
  std::int64_t t_ns = 0;
  std::int64_t td_ns = 0;  // the camera-IMU offset t_ns carries (StereoFrame::td_ns)
  std::uint64_t seq = 0;
  FixedVector<FeatureObservation, capacity::kMaxFeaturesPerCamera> features;  // max_cnt <= this
  int n_3d = 0;
  int n_2d_left = 0;
  int n_2d_right = 0;
  FrontendFrameStats stats;

  void clear() {
    features.clear();
    n_3d = n_2d_left = n_2d_right = 0;
    stats = FrontendFrameStats{};
  }
};

}  // namespace ums
