#pragma once
// A flight at the level of features, without images: the simulator's trajectory and IMU, points
// on the walls of a room around the path, and a front end that hands the estimator exact (or
// noisy) bearings with the track ids, classes and counts a real one would. It separates what the
// estimator's model does from what the image front end adds.

#include <cstdint>
#include <string>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "core/estimator/estimator.hpp"

namespace ums::test {

struct FeatureFlightOptions {
  std::string trajectory;             // shared *_GT.txt path
  double start_s = 0.0, duration_s = 60.0;  // s, the cut of the trajectory
  double noise_px = 0.0;              // px at the camera's focal length, std of the bearing noise per axis
  double noise_right_px = -1.0;       // right camera's (< 0: noise_px)
  bool stereo = true;                 // false: left camera only
  bool imu_noise = false;             // the calibrated white noise and random walk
  bool vo_only = false;               // never align (the estimator stays in VO)
  int max_tracks = 150;               // tracked features at a time (the front end's max_cnt)
  double min_spacing_px = 30.0;       // px, new features at least this far from tracked ones
  double wall_margin_m = 2.5;         // m, walls beyond the path's bounding box (the procedural room)
  int points = 6000;                  // on the room's six faces
  std::uint64_t seed = 1;             // points, noise and the simulator's IMU
  double blackout_start_s = -1.0;     // s into the cut: no features from here (< 0: none)
  double blackout_s = 0.0;            // s, for this long; every track is lost
  double imu_gap_start_s = -1.0;      // s into the cut: IMU samples lost from here (< 0: none)
  double imu_gap_s = 0.0;             // s, for this long
  EstimatorOptions estimator;
  KeyframeSink* keyframe_sink = nullptr;   // not owned: the estimator's keyframe outlet
  RelocationLink* relocation = nullptr;    // not owned: tightly coupled relocation
};

struct FeatureFlightResult {
  int frames = 0, valid_frames = 0, vio_frames = 0;
  double ate_m = 0.0;                 // m, after an SE(3) alignment of every valid frame
  double yaw_drift_deg_min = 0.0;     // deg/min, slope of the world-z rotation error over time
  double yaw_per_heading = 0.0;       // 1, slope of the world-z rotation error over the true heading
  double final_rot_err_deg = 0.0;     // deg, rotation error of the last frame
  // Per valid frame: time (s), aligned position error (m), world-z rotation error (deg, taken
  // against the error 1 s into VIO or into the run) and the true heading (deg, unwrapped).
  std::vector<double> t_s;
  std::vector<Eigen::Vector3d> p_err_m;
  std::vector<double> yaw_err_deg, heading_deg;
  // Every frame, valid or not: time (s into the cut), mode, position finite, reset_counter.
  std::vector<double> frame_t_s;
  std::vector<EstimatorMode> frame_mode;
  std::vector<bool> frame_finite;
  std::vector<std::uint32_t> frame_reset_counter;
  EstimatorStats stats;  // the estimator's counters at the end
};

// Flies o.trajectory through the estimator at the camera rate of the EuRoC preset.
FeatureFlightResult fly_features(const FeatureFlightOptions& options);

}  // namespace ums::test
