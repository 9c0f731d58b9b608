#include "core/estimator/estimator_options.hpp"

#include <stdexcept>
#include <string>

#include "core/common/capacity.hpp"

namespace ums {
namespace {

void require(bool ok, const char* field, double value) {
  if (!ok) throw std::invalid_argument(std::string("EstimatorOptions.") + field + " = " + std::to_string(value) + " is out of range");
}

}  // namespace

void EstimatorOptions::validate() const {
  require(sigma_px > 0.0, "sigma_px", sigma_px);
  require(focal_px > 0.0, "focal_px", focal_px);
  require(beta_3d > 0.0, "beta_3d", beta_3d);
  require(beta_2d > 0.0, "beta_2d", beta_2d);
  require(huber_px > 0.0, "huber_px", huber_px);
  require(gravity_m_s2 > 5.0 && gravity_m_s2 < 15.0, "gravity_m_s2", gravity_m_s2);
  require(window_size >= 4 && window_size <= static_cast<int>(capacity::kWindowSize), "window_size", window_size);
  require(max_landmarks_in_solve >= 10 && max_landmarks_in_solve <= static_cast<int>(capacity::kMaxLandmarks),
          "max_landmarks_in_solve", max_landmarks_in_solve);
  require(min_depth_m > 0.0 && max_depth_m > min_depth_m, "max_depth_m", max_depth_m);
  require(min_triangulation_angle_deg > 0.0, "min_triangulation_angle_deg", min_triangulation_angle_deg);
  require(outlier_px > 0.0, "outlier_px", outlier_px);
  require(max_iterations_stage >= 1, "max_iterations_stage", max_iterations_stage);
  require(max_iterations_stage_a >= 1, "max_iterations_stage_a", max_iterations_stage_a);
  require(max_steps_stage >= 0, "max_steps_stage", max_steps_stage);
  require(share_2d >= 0.0 && share_2d <= 1.0, "share_2d", share_2d);
  require(max_iterations_round2 >= 0, "max_iterations_round2", max_iterations_round2);
  require(round2_time_s >= 0.0, "round2_time_s", round2_time_s);
  require(round2_min_outlier_share >= 0.0 && round2_min_outlier_share <= 1.0, "round2_min_outlier_share",
          round2_min_outlier_share);
  require(predicted_stop_share >= 0.0 && predicted_stop_share <= 1.0, "predicted_stop_share",
          predicted_stop_share);
  require(min_align_frames >= 3 && min_align_frames <= window_size, "min_align_frames", min_align_frames);
  require(align_max_tilt_sigma_deg > 0.0, "align_max_tilt_sigma_deg", align_max_tilt_sigma_deg);
  require(align_min_excitation_m_s2 > 0.0, "align_min_excitation_m_s2", align_min_excitation_m_s2);
  require(standstill_window_s >= standstill.min_window_s, "standstill_window_s", standstill_window_s);
  require(still_sigma_m > 0.0 && still_sigma_rad > 0.0 && still_sigma_v > 0.0, "still_sigma_m", still_sigma_m);
  require(imu_noise_inflation > 0.0, "imu_noise_inflation", imu_noise_inflation);
  require(imu_walk_inflation > 0.0, "imu_walk_inflation", imu_walk_inflation);
  require(min_stereo_disparity_px >= 0.0, "min_stereo_disparity_px", min_stereo_disparity_px);
  require(landmark_spread_px >= 0.0, "landmark_spread_px", landmark_spread_px);
  require(stage_min_2d_left >= 0, "stage_min_2d_left", stage_min_2d_left);
  require(extrinsic_release_deg >= 0.0, "extrinsic_release_deg", extrinsic_release_deg);
  require(extrinsic_sigma_m > 0.0, "extrinsic_sigma_m", extrinsic_sigma_m);
  require(extrinsic_sigma_deg > 0.0, "extrinsic_sigma_deg", extrinsic_sigma_deg);
  require(baseline_sigma_m > 0.0, "baseline_sigma_m", baseline_sigma_m);
  require(baseline_sigma_deg > 0.0, "baseline_sigma_deg", baseline_sigma_deg);
  require(td_sigma_ms > 0.0, "td_sigma_ms", td_sigma_ms);
  require(td_max_change_ms > 0.0, "td_max_change_ms", td_max_change_ms);
  require(imu_max_gap_ms > 0.0 && imu_max_gap_ms <= 10000.0, "imu_max_gap_ms", imu_max_gap_ms);
  require(min_tracked_landmarks >= 0, "min_tracked_landmarks", min_tracked_landmarks);
  require(vision_lost_after_s >= 0.0 && vision_lost_after_s <= 60.0, "vision_lost_after_s", vision_lost_after_s);
  require(vision_back_after_s >= 0.0 && vision_back_after_s <= 60.0, "vision_back_after_s", vision_back_after_s);
  require(gyro_scale_sigma_pct > 0.0, "gyro_scale_sigma_pct", gyro_scale_sigma_pct);
  require(gyro_scale_max_pct > 0.0, "gyro_scale_max_pct", gyro_scale_max_pct);
  preintegration.validate();
  keyframe.validate();
  standstill.validate();
}

}  // namespace ums
