#pragma once
// The realistic IMU (issue 18 item 3, `umsvins simulate --imu-model realistic`): errors a MEMS IMU
// on a small drone has and the estimator's model (white noise + bias random walk, imu_noise.hpp)
// does not: rotor vibration, per-axis scale factors, axis misalignment, and a slow warm-up bias
// drift. Applied to an ImuTrack's measured samples after the style's generator; the ground-truth
// poses and velocities are untouched (the truth's biases gain the drift: it is a bias).
//
// Measurement model, per sensor (gyro and accel alike), with b the generator's bias and n its noise:
//   y = M (x + n) + b + d(t) + v(t),   M = diag(1 + s) (I + N)
//   s: scale-factor errors, uniform in +-scale_max per axis;
//   N: zero diagonal, N(i,j) uniform in +-misalignment_max: sensing axis i leans towards axis j
//      (non-orthogonal axes, not a rotation: the six angles are independent);
//   d(t) = d_end (1 - exp(-t / tau)): warm-up drift from the start of the track, d_end per axis
//      with a random sign and a magnitude uniform in [0.5, 1] x drift;
//   v(t): vibration, narrow-band noise near the rotor frequency, seen through the IMU's sampling.
// Deterministic per seed, from a stream of its own (the ideal output never draws from it).

#include <cstdint>
#include <string>

#include <Eigen/Core>

namespace ums::sim {

struct ImuTrack;

enum class ImuModel : std::uint8_t {
  kIdeal,      // errors as the estimator models them (the default; output unchanged)
  kRealistic,  // + ImuErrorOptions' errors
};
bool parse_imu_model(const std::string& name, ImuModel* model);
const char* imu_model_name(ImuModel model);

// Defaults: a small quadrotor, soft-mounted consumer IMU (BMI055-class). See docs/simulator.md
// "Realistic IMU" for the reasoning behind each number.
struct ImuErrorOptions {
  // Vibration: a small quad's rotors turn at 6000-9000 rpm (100-150 Hz) and their imbalance
  // shakes the frame once per revolution; behind soft mounting a few tenths of m/s^2 and a few
  // hundredths of rad/s remain. The band is evaluated at the sample stamps (point sampling), so
  // it aliases as the IMU's sampling folds it (130 Hz at 200 Hz -> 70 Hz); the RMS is the one the
  // samples show, i.e. after whatever the IMU's internal low-pass let through.
  double vibration_centre_hz = 130.0;       // Hz, mechanical frequency at the band's centre
  double vibration_width_hz = 20.0;         // Hz, full width of the band (rotor speed changes)
  double vibration_accel_rms_m_s2 = 0.5;    // m/s^2, RMS per axis as the samples show it
  double vibration_gyro_rms_rad_s = 0.02;   // rad/s, RMS per axis as the samples show it
  // Scale factor and misalignment (consumer MEMS datasheets, BMI055-class: sensitivity tolerance
  // of about +-1 %, cross-axis sensitivity of 1-2 %; from memory, see docs/simulator.md).
  double gyro_scale_max = 0.005;            // dimensionless, |s| <= this per axis (0.5 %)
  double accel_scale_max = 0.005;           // dimensionless
  double gyro_misalignment_max_rad = 0.2 * 3.14159265358979323846 / 180.0;   // rad (0.2 deg)
  double accel_misalignment_max_rad = 0.2 * 3.14159265358979323846 / 180.0;  // rad (0.2 deg)
  // Warm-up drift (offset temperature coefficients of BMI055-class parts, ~0.015 deg/s/K and
  // ~1 mg/K from memory; a board warming by ~5-10 K in the first minutes of a flight).
  double gyro_drift_rad_s = 0.002;          // rad/s, largest per-axis drift at t >> tau
  double accel_drift_m_s2 = 0.05;           // m/s^2, largest per-axis drift at t >> tau
  double drift_time_constant_s = 60.0;      // s, thermal time constant of the warm-up
  bool validate(std::string* error) const;
};

// Keeps only the errors named in `list` (comma-separated: vibration, scale, misalignment, drift;
// "all": every one) and zeroes the others' sizes, to tell their effects apart. false: unknown name.
bool select_imu_errors(const std::string& list, ImuErrorOptions* options);

// What one seed drew: the planted values, recorded in sim_events.csv and measured back in tests.
struct ImuErrorDraw {
  Eigen::Matrix3d M_gyro = Eigen::Matrix3d::Identity();   // y = M x: scale and misalignment
  Eigen::Matrix3d M_accel = Eigen::Matrix3d::Identity();
  Eigen::Vector3d gyro_scale = Eigen::Vector3d::Zero();   // s (dimensionless)
  Eigen::Vector3d accel_scale = Eigen::Vector3d::Zero();
  Eigen::Vector3d gyro_drift_end_rad_s = Eigen::Vector3d::Zero();   // d_end
  Eigen::Vector3d accel_drift_end_m_s2 = Eigen::Vector3d::Zero();
};

ImuErrorDraw draw_imu_errors(const ImuErrorOptions& options, std::uint64_t seed);

// Applies `draw` and the vibration (its own draws from seed) to track->samples, using
// track->truth's biases to keep the bias outside M; adds the drift to track->truth's biases.
void apply_imu_errors(const ImuErrorOptions& options, const ImuErrorDraw& draw, std::uint64_t seed, ImuTrack* track);

// One line for sim_events.csv's header ("#imu_model: realistic, ...") with the settings and the
// drawn scale factors, misalignment matrices and drift ends.
std::string imu_errors_header(const ImuErrorOptions& options, const ImuErrorDraw& draw);

}  // namespace ums::sim
