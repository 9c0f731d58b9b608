#pragma once
// Options of the estimator (paper Sec. III-B and III-C). Every field has a unit and a default
// that works on EuRoC-like rigs at 20 Hz and on the D455; validate() checks ranges and the
// compile-time capacities.

#include "core/frontend/keyframe_selector.hpp"
#include "core/imu/imu_noise.hpp"
#include "core/imu/preintegration.hpp"
#include "core/imu/standstill.hpp"

namespace ums {

struct EstimatorOptions {
  // --- measurement model ---
  double sigma_px = 1.5;             // px, feature noise (VINS-Fusion: focal / 1.5)
  double focal_px = 460.0;           // px, turns sigma_px into radians on the bearing tangent plane
  double beta_3d = 1.0;              // 1, paper eq. (5) beta1: weight of 3D (stereo) landmarks' residuals
  double beta_2d = 1.0;              // 1, paper eq. (5) beta2: weight of 2D (one-camera) landmarks' residuals
  double huber_px = 1.5;             // px, Huber threshold on the visual residuals
  double gravity_m_s2 = 9.81;        // m/s^2
  bool estimate_extrinsic = false;   // optimize T_b_c0 / T_b_c1 in the window
  // With estimate_extrinsic: the extrinsics stay at the calibration until the window's rotation
  // excitation (about its least-excited axis, Estimator::rotation_excitation_deg) first reaches
  // extrinsic_release_deg; then they float in the VIO solves under a prior around the
  // calibration, with the stereo pair's relative pose held to the calibrated one (baseline sigmas).
  double extrinsic_release_deg = 1.0;
  double extrinsic_sigma_m = 0.05, extrinsic_sigma_deg = 3.0;
  double baseline_sigma_m = 0.0005, baseline_sigma_deg = 0.05;
  // Estimate the camera-IMU time offset (t_imu = t_cam + td) in the VIO solves, starting from the
  // calibration's td (which the pipeline has already applied to the frames) under a prior of
  // td_sigma_ms, and kept within td_max_change_ms of it (time_offset.hpp).
  bool estimate_td = false;
  double td_sigma_ms = 50.0;
  double td_max_change_ms = 30.0;
  // Estimate the gyroscope's per-axis scale-factor error in the VIO solves (gyro_scale.hpp), under
  // a prior of gyro_scale_sigma_pct around zero, kept within gyro_scale_max_pct.
  bool estimate_gyro_scale = false;
  double gyro_scale_sigma_pct = 1.0;
  double gyro_scale_max_pct = 3.0;
  PreintegrationOptions preintegration;  // noise: set from the rig calibration by the caller
  double imu_noise_inflation = 2.0;   // 1, multiplies the calibrated white-noise densities:
                                      // unmodelled vibration and timing (VINS-Fusion: EuRoC ~10x)
  double imu_walk_inflation = 6.0;    // 1, multiplies the calibrated bias random walks: the
                                      // biases between keyframes seconds apart must be free to
                                      // move (docs/results.md "Weights" has the measurement)
  // ms: a longer time between IMU samples is a hole (samples lost), counted per frame whose IMU
  // interval spans one (stats imu_gap_frames). Far above any IMU's period (5 ms at 200 Hz, 16 ms
  // for a D455's 63 Hz accel). The interval is still integrated with the last sample held across
  // the hole: what to do instead is open (docs/robustness.md).
  double imu_max_gap_ms = 50.0;
  KeyframeOptions keyframe;

  // --- window and features ---
  int window_size = 11;                   // frames incl. the newest (<= capacity::kWindowSize)
  int max_landmarks_in_solve = 150;       // landmarks per solve, best first (paper: best 100-300)
  double min_depth_m = 0.1;               // m, landmarks closer are rejected
  double max_depth_m = 60.0;              // m, landmarks farther are not used (no parallax)
  double landmark_spread_px = 0.0;        // px at focal_px: > 0 spreads the landmarks of a solve
                                          // over the view in cells of this size (landmark_selection.hpp)
  double min_stereo_disparity_px = 0.0;   // px at focal_px: a stereo match with less disparity
                                          // carries no depth and enters as a 2D feature
  double min_triangulation_angle_deg = 0.4;  // deg, ray angle needed to triangulate a 2D feature
  double outlier_px = 3.0;                // px, observation error that marks a landmark as an outlier

  // --- two-stage solve (paper Sec. III-C) ---
  int min_3d_landmarks = 25;              // fewer 3D landmarks in the window: add 2D-right at once
  int stage_min_2d_left = 10;             // fewer 2D-left candidates: one solve with them, no
                                          // stereo-only comparison (0: always compare, the paper)
  double stage_agree_m = 0.05;            // m, stereo vs mono-stereo newest pose agreement
  double stage_agree_deg = 1.0;           // deg
  int max_iterations_stage = 3;           // LM iterations of the first-round solve that is kept
  int max_iterations_stage_a = 1;         // LM iterations of the stereo-only check solve
  int max_steps_stage = 1;                // accepted LM steps of a first-round solve (0: until a
                                          // tolerance or max_iterations_stage). The solve ends
                                          // without linearizing at its last step; the next frame's
                                          // solve continues from there (docs/estimator.md)
  bool max_steps_at_keyframes = false;    // false: a keyframe's solves run to convergence (its
                                          // oldest frame and landmarks enter the prior from them)
  double share_2d = 0.3;                  // 1, share of the landmark budget offered to 2D features
  int max_iterations_round2 = 4;          // LM iterations of the second round
  double round2_time_s = 0.010;           // s, time budget of the second round (paper: bounded)
  // A converged round 1 is solved again only when its outliers are at least this share of its
  // landmarks: a few down-weighted (Huber) rays of a converged window leave the next frame's solve
  // (as VINS-Fusion does) instead of costing a solve of their own (over 28 flights: 1 s RPE
  // +0.3 %, 10 s RPE and ATE unchanged; docs/performance.md, session 39). 0: any outlier (the paper).
  double round2_min_outlier_share = 0.02;  // 1
  double function_tolerance = 1e-3;       // 1, relative cost change that ends a solve (converged)
  double predicted_stop_share = 0.5;      // 1, a step whose model change is below this share of
                                          // the function tolerance ends the solve unevaluated
                                          // (SolverOptions::predicted_stop_share; 0: Ceres)
  bool reuse_gauss_newton_matrix = true;  // the first accepted step forms only the gradient
                                          // again (SolverOptions::reuse_gauss_newton_matrix)
  bool reuse_factorization = true;        // the step after that gradient pass is solved with the
                                          // step before's factor (SolverOptions::reuse_factorization)
  bool two_stage = true;                  // false: one solve with every feature class

  // --- initialization (paper Sec. III-B) ---
  int min_init_3d = 20;                   // 3D features with depth needed for visual init / PnP
  int min_align_frames = 8;               // window frames needed for the visual-IMU alignment
  double min_align_span_s = 0.45;         // s, time spanned by them
  double max_gravity_error_m_s2 = 0.6;    // m/s^2, | |g_LS| - g | accepted from the least squares
  double align_max_tilt_sigma_deg = 0.5;  // deg, the window's information must give gravity's
                                          // direction this well (1 sigma, b_a prior included)
  double align_min_excitation_m_s2 = 0.2; // m/s^2, ... or the accelerometer must be this excited
                                          // (RMS spread of the intervals' mean accelerations)
  int align_retry_frames = 10;             // frames between alignment attempts in VO
  double init_bias_sigma_ba = 0.2;        // m/s^2, prior on b_a at initialization
  double init_bias_sigma_bg = 0.02;       // rad/s, prior on b_g at initialization

  // --- standstill (zero-velocity handling) ---
  StandstillOptions standstill;
  double standstill_window_s = 0.5;       // s of IMU examined before each frame
  double still_sigma_m = 0.002;           // m, zero-motion constraint between still frames
  double still_sigma_rad = 0.001;         // rad
  double still_sigma_v = 0.01;            // m/s, zero-velocity constraint
  double still_max_flow_px = 0.5;         // px, mean de-rotated feature motion between frames above
                                          // which an IMU standstill is uniform motion instead

  // --- failure handling ---
  // VIO reports VISION_LOST (the pose is the IMU's) when its frames see fewer than
  // min_tracked_landmarks tracked landmarks for vision_lost_after_s, and VIO again when they see
  // that many for vision_back_after_s. A single dark frame changes nothing.
  int min_tracked_landmarks = 10;          // landmarks tracked into a new frame
  double vision_lost_after_s = 0.25;       // s
  double vision_back_after_s = 0.25;       // s
  double max_speed_m_s = 20.0;             // m/s, beyond it the window is reset (divergence)

  void validate() const;  // throws std::invalid_argument naming the field and value
};

}  // namespace ums
