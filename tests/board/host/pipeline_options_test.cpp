#include "board/host/pipeline_options.hpp"

#include <catch2/catch.hpp>

#include <cmath>

namespace ums::cli {

// Every key of the configuration file that configures the front end or the estimator, set to a
// value no default has, must arrive in the options: a key read but not passed on would be
// accepted and silently do nothing.
TEST_CASE("every front-end key of the configuration reaches the front end's options", "[config][cli]") {
  AppConfig c;
  c.max_cnt = 137;
  c.detect_min_missing = 11;
  c.detect_interval = 5;
  c.klt_sparse_from_level = 2;
  c.klt_confirm_sparse_from_level = 1;
  c.stereo_confirm_tracked = !FrontendOptions{}.stereo_confirm_tracked;
  c.min_dist_px = 31.5;
  c.f_threshold_px = 0.75;
  const FrontendOptions o = frontend_options_from(c);
  CHECK(o.max_cnt == 137);
  CHECK(o.detect_min_missing == 11);
  CHECK(o.detect_interval == 5);
  CHECK(o.klt.sparse_from_level == 2);
  CHECK(o.confirm_sparse_from_level == 1);
  CHECK(o.stereo_confirm_tracked == c.stereo_confirm_tracked);
  CHECK(o.detector.min_distance_px == 31.5f);
  CHECK(o.ransac.threshold_px == 0.75f);
}

TEST_CASE("every estimator key of the configuration reaches the estimator's options", "[config][cli]") {
  AppConfig c;
  c.rig.cam[0].fx = 433.0;
  c.rig.imu.gyro_noise_density = 3e-4;
  c.rig.imu.accel_noise_density = 4e-3;
  c.rig.imu.gyro_random_walk = 5e-5;
  c.rig.imu.accel_random_walk = 6e-3;
  c.keyframe_parallax_px = 12.5;
  c.estimate_extrinsic = true;
  c.estimate_td = true;
  c.estimate_gyro_scale = true;
  c.max_num_iterations = 7;
  c.max_steps_per_solve = 2;
  c.max_steps_at_keyframes = true;
  c.reuse_gauss_newton_matrix = false;
  c.reuse_factorization = false;
  c.max_solver_time_s = 0.025;
  c.imu_noise_scale = 1.5;
  c.imu_walk_scale = 3.5;
  c.max_landmarks_in_solve = 123;
  c.beta_3d = 1.25;
  c.beta_2d = 0.75;
  c.min_stereo_disparity_px = 0.5;
  c.feature_sigma_px = 1.25;
  c.landmark_spread_px = 40.0;
  c.stage_min_2d_left = 7;
  c.huber_px = 2.5;
  c.outlier_px = 4.5;
  c.max_speed_m_s = 12.0;
  c.round2_min_outlier_share = 0.125;
  const EstimatorOptions o = estimator_options_from(c, false);
  CHECK(o.focal_px == 433.0);
  CHECK(o.keyframe.focal_px == 433.0f);
  CHECK(o.keyframe.min_parallax_px == 12.5f);
  CHECK(o.preintegration.noise.gyro_noise_density == 3e-4);
  CHECK(o.preintegration.noise.accel_noise_density == 4e-3);
  CHECK(o.preintegration.noise.gyro_random_walk == 5e-5);
  CHECK(o.preintegration.noise.accel_random_walk == 6e-3);
  CHECK(o.estimate_extrinsic);
  CHECK(o.estimate_td);
  CHECK(o.estimate_gyro_scale);
  CHECK(o.max_iterations_round2 == 7);
  CHECK(o.max_steps_stage == 2);
  CHECK(o.max_steps_at_keyframes);
  CHECK(!o.reuse_gauss_newton_matrix);
  CHECK(!o.reuse_factorization);
  CHECK(o.round2_time_s == 0.025);
  CHECK(o.imu_noise_inflation == 1.5);
  CHECK(o.imu_walk_inflation == 3.5);
  CHECK(o.max_landmarks_in_solve == 123);
  CHECK(o.beta_3d == 1.25);
  CHECK(o.beta_2d == 0.75);
  CHECK(o.min_stereo_disparity_px == 0.5);
  CHECK(o.sigma_px == 1.25);
  CHECK(o.landmark_spread_px == 40.0);
  CHECK(o.stage_min_2d_left == 7);
  CHECK(o.huber_px == 2.5);
  CHECK(o.outlier_px == 4.5);
  CHECK(o.max_speed_m_s == 12.0);
  CHECK(o.round2_min_outlier_share == 0.125);
}

TEST_CASE("a deterministic replay bounds the second round by its iterations, not the wall clock", "[config][cli]") {
  AppConfig c;
  c.max_solver_time_s = 0.025;
  CHECK(std::isinf(estimator_options_from(c, true).round2_time_s));
  CHECK(estimator_options_from(c, false).round2_time_s == 0.025);
  // Without a focal length in the rig the estimator keeps its own.
  c.rig.cam[0].fx = 0.0;
  CHECK(estimator_options_from(c, false).focal_px == EstimatorOptions{}.focal_px);
}

}  // namespace ums::cli
