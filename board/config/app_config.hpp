#pragma once
// The program's configuration: the rig calibration plus the tuning keys, as a plain struct.
// Read from an OpenCV FileStorage YAML file ("%YAML:1.0", the format VINS-Fusion uses); the
// VINS-Fusion stereo-IMU keys are accepted where they mean the same thing, so an existing
// VINS-Fusion config (with its camodocal camN_calib files) works unchanged. Without a config the
// dataset's sensor.yaml calibration and the defaults below are used (config_from_calibration).
//
// Tuning keys, calibration and compile-time capacities are kept apart: the keys choose values up
// to the capacities of core/common/capacity.hpp, never beyond. docs/replay-and-config.md has the
// key table.

#include <string>
#include <vector>

#include "core/common/calibration.hpp"

namespace ums {

struct AppConfig {
  RigCalibration rig;  // cameras, IMU noise, gravity (g_norm) and td

  // Front end
  int max_cnt = 200;                    // features per frame, 3D + 2D-left + 2D-right (VINS max_cnt)
  double min_dist_px = 25.0;            // px, minimum distance between features (VINS min_dist)
  double f_threshold_px = 1.0;          // px, epipolar RANSAC inlier threshold (VINS F_threshold)
  int detect_min_missing = 1;           // features missing before a new detection (ours; <= max_cnt)
  int detect_interval = 2;              // frames: a top-up at most every this many (ours; 1: any frame)
  int klt_sparse_from_level = 4;        // KLT levels from this one up iterate on every other pixel (4: none)
  int klt_confirm_sparse_from_level = 0;  // the same for the forward-backward confirmation tracks
  bool stereo_confirm_tracked = false;  // a tracked feature's stereo match also confirmed right->left
  // Keyframes
  double keyframe_parallax_px = 10.0;   // px at a 460 px focal length (VINS keyframe_parallax)
  // Back end
  double max_solver_time_s = 0.04;      // s, wall-time bound of one window solve (VINS max_solver_time)
  int max_num_iterations = 8;           // solver iterations per window solve (VINS max_num_iterations)
  double round2_min_outlier_share = 0.02;  // 1, EstimatorOptions::round2_min_outlier_share
  int max_steps_per_solve = 1;          // accepted LM steps per first-round window solve (0: until converged)
  bool max_steps_at_keyframes = false;  // the budget also at keyframes (false: they converge)
  bool reuse_gauss_newton_matrix = true;   // window solves: at the first step, the gradient only
  bool reuse_factorization = true;         // ... and the step after it from the step before's factor
  bool estimate_extrinsic = false;      // refine T_b_c around the given values (VINS estimate_extrinsic 1)
  bool estimate_td = false;             // estimate the camera-IMU time offset (VINS estimate_td)
  bool estimate_gyro_scale = false;     // estimate the gyro's per-axis scale-factor error
  // Back-end weights (ours; docs/results.md "Weights" has the measurements behind the defaults)
  double imu_noise_scale = 2.0;         // 1, multiplies the calibrated IMU white-noise densities
  double imu_walk_scale = 6.0;          // 1, multiplies the calibrated IMU bias random walks
  int max_landmarks_in_solve = 150;     // landmarks per window solve, best first (paper: 100-300)
  double beta_3d = 1.0;                 // 1, paper eq. (5) beta1: weight of 3D landmarks' residuals
  double beta_2d = 1.0;                 // 1, paper eq. (5) beta2: weight of 2D landmarks' residuals
  double min_stereo_disparity_px = 0.0; // px, a stereo match with less disparity counts as 2D
  double landmark_spread_px = 0.0;      // px, cells over which a solve's landmarks are spread (0: off)
  int stage_min_2d_left = 10;           // 2D-left landmarks below which the stage comparison is skipped
  double feature_sigma_px = 1.5;        // px, feature noise that whitens the visual residuals
  double huber_px = 1.5;                // px, Huber threshold on the visual residuals
  double outlier_px = 3.0;              // px, an observation this far off marks its landmark an outlier
  double max_speed_m_s = 20.0;          // m/s, divergence guard: a faster estimate resets the window
                                        // (72 km/h: a car at 15-25 km/h, a drone, are far below it)

  // Output to a flight controller (MAVLink, docs/mavlink.md): the vehicle's FRD body in the
  // estimator's body (IMU) frame. Only its rotation is used; the lever arm is the flight
  // controller's parameter (EKF2_EV_POS_* / VISO_POS_*).
  Eigen::Isometry3d T_b_vehicle = Eigen::Isometry3d::Identity();

  std::string source;                   // where it came from: the config path, or "sensor.yaml"

  // Throws std::invalid_argument "AppConfig.<field> = <value>: allowed <range>".
  void validate() const;
};

// Defaults plus the given calibration (the dataset's sensor.yaml files).
AppConfig config_from_calibration(const RigCalibration& calibration);

// Reads path over config_from_calibration(defaults). Keys absent from the file keep the
// defaults' values. Unknown keys add "<file>: unknown key '<k>' ignored" to *warnings (may be
// null); invalid values throw std::runtime_error "<file>: key '<k>' = <value>: allowed <range>";
// unreadable files and camN_calib files throw naming the file.
AppConfig load_config(const std::string& path, const RigCalibration& defaults,
                      std::vector<std::string>* warnings);

}  // namespace ums
