#pragma once
// The window's landmarks: a fixed Pool of Landmark objects and an index sorted by feature id
// (ids grow over a run, so inserting is almost always an append; iteration is in id order, which
// fixes the order residuals enter a solve). It ingests a frame's features, removes a frame's
// observations (moving the depth of the landmarks that frame hosted to their next observation),
// triangulates, and drops landmarks without observations or marked as outliers.

#include <cstdint>
#include <memory>

#include <Eigen/Core>

#include "core/common/capacity.hpp"
#include "core/common/pool.hpp"
#include "core/estimator/landmark.hpp"
#include "core/frontend/frame_features.hpp"

namespace ums {

class Window;

// Where a landmark goes when its host frame leaves the window and its next observation hosts it.
// The inverse-depth parametrization fixes the direction from the host, so the choice decides what
// the landmark keeps:
//  - kMeasuredRay (VINS-Fusion): the next observation's measured bearing at the same distance. The
//    point moves by that frame's pose error and bearing noise; the map inherits them. Right when
//    that frame's pose is held by the IMU and the prior (VIO): the measured ray is information the
//    1-DOF landmark would otherwise lose.
//  - kKeepPoint: the same world point, its direction from the new host as the anchor. Right when
//    nothing but vision holds the window (VO, whose oldest pose is the gauge): moving every point
//    onto the new host's rays at each keyframe makes the map drift with that frame's error.
// docs/results.md ("Rehosting") has the measurements behind the choice.
enum class Rehost : std::uint8_t { kMeasuredRay, kKeepPoint };

struct LandmarkMapOptions {
  double min_depth_m = 0.1;                 // m
  double max_depth_m = 60.0;                // m
  double min_triangulation_angle_deg = 0.4; // deg
  double min_stereo_parallax_rad = 0.0;     // rad, a stereo match with less ray angle (a far point:
                                            // disparity of a pixel or two) enters as 2D-left
};

class LandmarkMap {
 public:
  static constexpr int kCapacity = static_cast<int>(capacity::kMaxLandmarks);
  // Depths of every landmark (by pool index), to try a solve and take it back.
  struct DepthBackup {
    double inv_depth[capacity::kMaxLandmarks];
    bool has_depth[capacity::kMaxLandmarks];
  };

  explicit LandmarkMap(const LandmarkMapOptions& options);

  // Landmarks in id order: k in [0, size()).
  int size() const { return n_; }
  int pool_index(int k) const { return index_[k]; }
  Landmark& operator[](int k) { return pool_->item(static_cast<std::size_t>(index_[k])); }
  const Landmark& operator[](int k) const { return pool_->item(static_cast<std::size_t>(index_[k])); }
  // By pool index (stable while the landmark lives).
  Landmark& at_pool(int idx) { return pool_->item(static_cast<std::size_t>(idx)); }
  const Landmark& at_pool(int idx) const { return pool_->item(static_cast<std::size_t>(idx)); }
  int find(std::uint32_t id) const;  // pool index, -1 if absent

  // The frame's features as observations of window slot `slot`; returns how many found no room.
  // R_c0_c1 (right camera to left) measures a stereo match's parallax. prev_slot: the window
  // frame before this one (-1: none), dt_s after it; a feature seen there gets bearing velocities,
  // with the gyro's spin taken out of the difference when `motion` is valid.
  int ingest(const FrameFeatures& ff, int slot, const Eigen::Matrix3d& R_c0_c1, int prev_slot = -1,
             double dt_s = 0.0, const CameraMotion& motion = CameraMotion());
  // Removes the observations of a window frame, rehosting the landmarks it hosted, then compacts.
  void remove_frame(int slot, const Window& window, Rehost rehost);
  void clear_observations();  // every landmark leaves (then compacts)
  void compact();             // drops landmarks without observations or marked outliers

  bool triangulate(Landmark& l, const Window& window, int exclude_slot) const;
  void triangulate_all(const Window& window, int exclude_slot);
  Eigen::Vector3d point_w(const Landmark& l, const Window& window) const;
  // Observations of `slot` of landmarks with depth hosted elsewhere; n_2d: those not stereo there.
  int count_depth_observations(int slot, int* n_2d_with_depth) const;

  void save_depths(DepthBackup* b) const;
  void restore_depths(const DepthBackup& b);

  std::size_t peak() const { return pool_->peak(); }
  const LandmarkMapOptions& options() const { return options_; }

 private:
  bool too_far_for_stereo(const FeatureObservation& o, const Eigen::Matrix3d& R_c0_c1) const;
  int create(std::uint32_t id);
  void rehost(Landmark& l, const Window& window, Rehost how) const;

  LandmarkMapOptions options_;
  std::unique_ptr<Pool<Landmark, capacity::kMaxLandmarks>> pool_;
  std::unique_ptr<std::uint32_t[]> ids_;    // sorted
  std::unique_ptr<std::int16_t[]> index_;   // pool index, same order
  int n_ = 0;
};

}  // namespace ums
