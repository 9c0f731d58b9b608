#include "board/host/pipeline_options.hpp"

#include <limits>

namespace ums::cli {

FrontendOptions frontend_options_from(const AppConfig& config) {
  FrontendOptions o;
  o.max_cnt = config.max_cnt;
  o.detect_min_missing = config.detect_min_missing;
  o.detect_interval = config.detect_interval;
  o.klt.sparse_from_level = config.klt_sparse_from_level;
  o.confirm_sparse_from_level = config.klt_confirm_sparse_from_level;
  o.stereo_confirm_tracked = config.stereo_confirm_tracked;
  o.detector.min_distance_px = static_cast<float>(config.min_dist_px);
  o.ransac.threshold_px = static_cast<float>(config.f_threshold_px);
  return o;
}

EstimatorOptions estimator_options_from(const AppConfig& config, bool deterministic) {
  EstimatorOptions o;
  o.keyframe.min_parallax_px = static_cast<float>(config.keyframe_parallax_px);
  o.focal_px = config.rig.cam[0].fx > 0.0 ? config.rig.cam[0].fx : o.focal_px;
  o.keyframe.focal_px = static_cast<float>(o.focal_px);
  o.estimate_extrinsic = config.estimate_extrinsic;
  o.estimate_td = config.estimate_td;
  o.estimate_gyro_scale = config.estimate_gyro_scale;
  o.max_iterations_round2 = config.max_num_iterations;
  o.round2_min_outlier_share = config.round2_min_outlier_share;
  o.max_steps_stage = config.max_steps_per_solve;
  o.max_steps_at_keyframes = config.max_steps_at_keyframes;
  o.reuse_gauss_newton_matrix = config.reuse_gauss_newton_matrix;
  o.reuse_factorization = config.reuse_factorization;
  o.round2_time_s = deterministic ? std::numeric_limits<double>::infinity() : config.max_solver_time_s;
  o.preintegration.noise = ImuNoise::from_calibration(config.rig.imu);
  o.imu_noise_inflation = config.imu_noise_scale;
  o.imu_walk_inflation = config.imu_walk_scale;
  o.max_landmarks_in_solve = config.max_landmarks_in_solve;
  o.beta_3d = config.beta_3d;
  o.beta_2d = config.beta_2d;
  o.min_stereo_disparity_px = config.min_stereo_disparity_px;
  o.sigma_px = config.feature_sigma_px;
  o.landmark_spread_px = config.landmark_spread_px;
  o.stage_min_2d_left = config.stage_min_2d_left;
  o.huber_px = config.huber_px;
  o.outlier_px = config.outlier_px;
  o.max_speed_m_s = config.max_speed_m_s;
  return o;
}

}  // namespace ums::cli
