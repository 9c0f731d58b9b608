#pragma once
// A feature of the sliding window: its observations in window frames (referenced by frame slot,
// which does not move when the window slides) and its inverse distance along the unit bearing of
// its host observation (the first one in the window; left camera when the feature was seen
// there, else right). Classes of the paper (Sec. III-A.1): a landmark seen in both cameras of
// any window frame is a 3D landmark; otherwise it is 2D-left or 2D-right by its camera.

#include <cstdint>

#include <Eigen/Core>

#include "core/common/capacity.hpp"

namespace ums {

struct LandmarkObservation {
  std::uint8_t slot = 0;        // window frame slot
  bool has_left = false;
  bool has_right = false;
  Eigen::Vector3f bearing_left = Eigen::Vector3f::UnitZ();   // unit, cam0
  Eigen::Vector3f bearing_right = Eigen::Vector3f::UnitZ();  // unit, cam1
  // 1/s, the bearing's rate of change at this frame (landmark_map.cpp: its spin from the gyro when
  // the CameraMotion is known, plus the central difference over the frames before and after, one-sided
  // at the ends of a track, of what is left; a single sighting has its spin only): moves
  // the measurement to another time by the camera-IMU offset being estimated (estimate_td).
  Eigen::Vector3f velocity_left = Eigen::Vector3f::Zero();
  Eigen::Vector3f velocity_right = Eigen::Vector3f::Zero();
  bool has_rate_left = false;   // velocity_left holds a backward difference (from the frame before)
  bool has_rate_right = false;
};

// What the gyro says about the cameras between the previous window frame and this one (estimate_td):
// a bearing's rate is its spin -w x b, known at the frame's own time, plus a translational part,
// which is all the images are differenced for. Without it (valid false) the whole rate is
// differenced: it then lags half a frame at the newest frame and a first sighting has none.
struct CameraMotion {
  bool valid = false;
  Eigen::Matrix3f R_cur_prev[2];    // per camera: camera at this frame <- camera at the frame before
  Eigen::Vector3f w_cur_rad_s[2];   // per camera: angular rate at this frame, in that camera
  Eigen::Vector3f w_prev_rad_s[2];  // per camera: angular rate at the frame before, in that camera
};

enum class LandmarkGroup : std::uint8_t { k3D = 0, k2DLeft = 1, k2DRight = 2 };

struct Landmark {
  std::uint32_t id = 0;
  std::uint8_t host_slot = 0;
  std::uint8_t host_cam = 0;     // 0 left, 1 right
  bool stereo = false;           // seen in both cameras in some window frame (3D)
  bool has_depth = false;        // inv_depth is initialized
  bool outlier = false;          // marked after a solve; removed at the end of the frame
  std::uint32_t track_length = 0;  // frames, from the front end
  double inv_depth = 0.0;        // 1/m along b_host
  Eigen::Vector3d b_host = Eigen::Vector3d::UnitZ();
  std::uint8_t n_obs = 0;
  LandmarkObservation obs[capacity::kMaxObservationsPerLandmark];

  LandmarkGroup group() const {
    if (stereo) return LandmarkGroup::k3D;
    return host_cam == 0 ? LandmarkGroup::k2DLeft : LandmarkGroup::k2DRight;
  }
  int find_obs(int slot) const {
    for (int k = 0; k < n_obs; ++k)
      if (obs[k].slot == slot) return k;
    return -1;
  }
};

}  // namespace ums
