#pragma once
// The photo style's IMU: a MEMS-like sensor model sampled from the SE(3) trajectory, by a method
// independent of the procedural style's (which evaluates PoseSpline's analytic derivatives).
//
// An internal clock runs at internal_rate_hz (an integer multiple m of the output rate, h = dt/m).
// Around each output stamp t_n the sensor integrates over the window [t_n - dt/2, t_n + dt/2]
// (a centred boxcar: the decimation filter with its group delay compensated in the stamp):
//   gyro_n  = 1/dt sum_{j<m} Log(R_j^T R_{j+1})                  (exact rotation increments)
//   accel_n = trapezoid mean over j = 0..m of R_j^T (a_j - g_w),  a_j = (p_{j+1} - 2 p_j + p_{j-1}) / h^2
// with t_j = t_n - dt/2 + j h on the spline. The output then gets the sensor errors of the
// procedural style (white noise std = density sqrt(rate), bias random walk step = rw sqrt(dt)),
// but initial biases as large as real MEMS ones: uniform in +-gyro_bias_max_rad_s and
// +-accel_bias_max_m_s2 per axis (the real EuRoC V1_01 IMU at rest: gyro bias
// (-0.002, 0.021, 0.078) rad/s).
// Ground truth at t_n: pose from the spline, velocity by the central difference (p(t+h) - p(t-h)) / 2h.

#include <cstdint>

#include "core/common/calibration.hpp"
#include "hal/sim/imu_track.hpp"
#include "hal/sim/se3_spline.hpp"

namespace ums::sim {

struct DecimatedImuOptions {
  double output_rate_hz = 200.0;        // Hz, the dataset's IMU rate
  double internal_rate_hz = 2000.0;     // Hz, rounded to an integer multiple of the output rate
  double gravity_m_s2 = 9.81;           // m/s^2, along -z of the world
  double gyro_bias_max_rad_s = 0.08;    // rad/s, initial gyro bias uniform in +-this per axis
  double accel_bias_max_m_s2 = 0.1;     // m/s^2, initial accel bias uniform in +-this per axis
  bool impulses = false;                // `impulses` scenario (add_impulses)
  std::uint64_t seed = 1;
};

// Stamps t_begin_ns + n dt_ns up to t_end_ns. The spline must be valid on
// [t_begin_ns - dt/2 - h, t_end_ns + dt/2 + h] (see decimated_imu_margin_ns).
ImuTrack generate_decimated_imu(const Se3Spline& spline, std::int64_t t_begin_ns, std::int64_t t_end_ns,
                                const ImuCalibration& imu, const DecimatedImuOptions& options);

// Trajectory time the sensor window needs beyond the first and last stamp, ns.
std::int64_t decimated_imu_margin_ns(double output_rate_hz);

}  // namespace ums::sim
