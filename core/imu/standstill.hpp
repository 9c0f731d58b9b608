#pragma once
// Standstill detection and attitude from rest. The window is cut into short blocks and the spread
// (standard deviation across blocks, worst axis) of the block means is compared with the spread
// that white sensor noise alone would give, density / sqrt(block_s), times a multiplier.
// Averaging over blocks first removes the high-frequency vibration that a vehicle with running
// motors shows even when it stands on the floor, while slow rotation or acceleration (motion)
// survives. The multiplier is large because real vibration is far above the datasheet noise:
// on EuRoC V1_01 at rest the 50 ms block spread of the gyro is <= 0.0134 rad/s (17.6x the noise
// figure 7.6e-4) and in flight >= 0.039 rad/s (51x) in every 1 s window; 25x sits between
// (numbers in docs/math-imu.md). At rest the mean accelerometer is gravity in the body frame,
// which gives roll and pitch (yaw is unobservable and set to 0), and the mean gyro is the bias.

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <cstddef>

#include "core/common/imu_sample.hpp"
#include "core/common/status.hpp"
#include "core/imu/imu_noise.hpp"

namespace ums {

struct StandstillOptions {
  double block_s = 0.05;           // s, length of the blocks averaged before the spread
  double gyro_multiplier = 25.0;   // threshold = multiplier * gyro_noise_density / sqrt(block_s)
  double accel_multiplier = 25.0;  // threshold = multiplier * accel_noise_density / sqrt(block_s)
  double max_gravity_error_m_s2 = 0.5;  // m/s^2, allowed | |mean accel| - gravity |
  double gravity_m_s2 = 9.81;           // m/s^2, local gravity magnitude
  double min_window_s = 0.5;            // s, shorter windows give kNotEnoughData
  int min_blocks = 4;                   // count, blocks needed for a spread

  void validate() const;  // throws std::invalid_argument naming the field and value
};

struct StandstillResult {
  bool at_rest = false;
  double gyro_spread_rad_s = 0.0;     // worst-axis std of the block means
  double accel_spread_m_s2 = 0.0;     // worst-axis std of the block means
  double gyro_threshold_rad_s = 0.0;  // the thresholds used
  double accel_threshold_m_s2 = 0.0;
  double gravity_error_m_s2 = 0.0;                            // |mean accel| - gravity (signed)
  Eigen::Vector3d mean_gyro_rad_s = Eigen::Vector3d::Zero();  // = the gyro bias when at rest
  Eigen::Vector3d mean_accel_m_s2 = Eigen::Vector3d::Zero();
  // Attitude R_w_b with yaw 0 such that R_w_b * mean_accel points up (+z world); valid when at
  // rest (computed regardless). Stored x,y,z,w.
  Eigen::Quaterniond q_w_b = Eigen::Quaterniond::Identity();
  int blocks = 0;
};

// Examines samples[0..n) (time-ordered, roughly uniform rate). kNotEnoughData if the window is
// shorter than min_window_s or has fewer than min_blocks blocks; kInvalidInput on non-finite
// values or non-increasing time. Allocates nothing.
Status detect_standstill(const ImuSample* samples, std::size_t n, const ImuNoise& noise,
                         const StandstillOptions& options, StandstillResult* result);

// Roll/pitch attitude (yaw 0) whose body frame measures specific force f_b at rest:
// R_w_b * f_b / |f_b| = +z.
Eigen::Quaterniond attitude_from_gravity(const Eigen::Vector3d& f_b);

}  // namespace ums
