#pragma once
// The simulator backend (hal/sim): flies a real (or built-in) trajectory through a simulated
// room and writes an EuRoC-layout dataset (both cameras, IMU, state_groundtruth_estimate0 of the
// body = IMU frame, sensor.yaml files) through hal/replay's EurocWriter. Deterministic per seed.
//
// Pipeline: ground truth (shared *_GT.txt: cam0, q = R_CW; or EuRoC data.csv: body) -> body poses
// via T_b_c0 -> uniform 20 Hz control points -> cut [start, start + duration] -> scenario prefix
// -> continuous trajectory -> IMU and camera poses from it -> renderer -> writer. The car scenarios
// replace the first steps: their route's camera poses (car_route.hpp) -> body poses via T_b_c0 ->
// the same 20 Hz control points; and the room by a street (street_world.hpp).
//
// Two independent styles (SimStyle), so the estimator is not measured on one simulator only:
//  - procedural (the reference, unchanged): PoseSpline on SO(3) x R3, IMU at imu_rate_hz from
//    the spline's analytic derivatives, procedural room and textures (renderer.hpp);
//  - photo: Se3Spline (coupled SE(3)), IMU from rotation increments and position differences at
//    an internal rate, integrated and decimated (decimated_imu.hpp), real-sized initial biases;
//    a larger room textured with tiles of real EuRoC images (photo_world.hpp), uneven light,
//    vignetting and motion blur (photo_renderer.hpp, exposure.hpp).

#include <cstdint>
#include <functional>
#include <string>
#include <vector>

#include "core/common/calibration.hpp"
#include "core/common/imu_sample.hpp"
#include "hal/replay/euroc_groundtruth.hpp"
#include "hal/sim/exposure.hpp"
#include "hal/sim/imu_errors.hpp"
#include "hal/sim/imu_track.hpp"
#include "hal/sim/photo_renderer.hpp"
#include "hal/sim/photo_world.hpp"
#include "hal/sim/renderer.hpp"
#include "hal/sim/se3_spline.hpp"
#include "hal/sim/spline.hpp"
#include "hal/sim/street_world.hpp"

namespace ums::sim {

enum class Scenario : std::uint8_t {
  kNominal,
  kStandstillStart,  // 5 s at rest before the flight
  kUniformStart,     // 6 s of constant velocity and attitude before the flight (joined C2)
  kDarkStart,        // first 3 s of images black
  kTextureless,      // walls and ceiling textureless (floor and boxes keep texture)
  kImpulses,         // single-sample IMU spikes (30-80 m/s^2, 5-10 rad/s) at the highest yaw rates
  kRightDropout,     // right camera blank (black) for 4 s mid-flight
  kBlackout,         // both cameras black for SimOptions::blackout_s (2 s) mid-flight (vision lost, then back)
  // The paper's car (Sec. IV-B, car_route.hpp): own trajectory (no trajectory_path), street world
  // (street_world.hpp), procedural style only.
  kCarTurn,          // case 2: 25 m of uniform motion (IMU unexcited), a 9 m radius 90 deg turn; ~60 m
  kCarLoop,          // case 1: a closed 80 x 50 m rounded rectangle at 15-25 km/h; ~259 m
};
bool parse_scenario(const std::string& name, Scenario* scenario);
const char* scenario_name(Scenario scenario);
inline constexpr Scenario kAllScenarios[] = {Scenario::kNominal, Scenario::kStandstillStart,
                                             Scenario::kUniformStart, Scenario::kDarkStart,
                                             Scenario::kTextureless, Scenario::kImpulses,
                                             Scenario::kRightDropout, Scenario::kBlackout};
// The scenarios that bring their own trajectory and world (not in kAllScenarios, which all fly a
// given or the built-in trajectory).
inline constexpr Scenario kCarScenarios[] = {Scenario::kCarTurn, Scenario::kCarLoop};
bool is_car_scenario(Scenario scenario);

enum class SimStyle : std::uint8_t {
  kProcedural,  // the reference simulator (default; its output does not change)
  kPhoto,       // real-image textures, larger room, lens and light effects, SE(3) trajectory, decimated IMU
};
bool parse_style(const std::string& name, SimStyle* style);
const char* style_name(SimStyle style);

enum class CameraPreset : std::uint8_t { kEuroc, kD455 };
bool parse_camera_preset(const std::string& name, CameraPreset* preset);

// EuRoC: VI-Sensor calibration (cam0/cam1 sensor.yaml) + ADIS16448 densities. D455: 848x480
// IR pair, 95 mm baseline, undistorted pinhole, BMI055 densities (datasheet-derived).
RigCalibration rig_preset(CameraPreset preset);

struct SimOptions {
  std::string trajectory_path;        // shared *_GT.txt or EuRoC data.csv; empty: built-in loop
                                      // (car scenarios: must be empty, they drive their own route)
  Scenario scenario = Scenario::kNominal;
  std::uint64_t seed = 1;             // every random draw (noise, biases, boxes, textures)
  std::string out_dir;                // dataset folder (gets mav0/)
  double start_s = 0.0;               // s into the trajectory where the cut starts
  double duration_s = 60.0;           // s of flight after start_s; <= 0: to the end
  CameraPreset camera_preset = CameraPreset::kEuroc;
  double camera_rate_hz = 20.0;       // Hz
  double imu_rate_hz = 200.0;         // Hz
  double gravity_m_s2 = 9.81;         // m/s^2
  double initial_gyro_bias_sigma_rad_s = 0.002;   // per-axis std of the initial gyro bias, rad/s
  double initial_accel_bias_sigma_m_s2 = 0.02;    // per-axis std of the initial accel bias, m/s^2
  bool exposure_change = false;       // slow exposure oscillation, +-35 % over 8 s
  double blackout_s = 2.0;            // s, kBlackout: both cameras black this long, centred mid-flight
  int max_frames = -1;                // render only the first N pairs (tests); < 0: all
  // Real sensors (issue 18), all off by default:
  // The accelerometer at this rate (a divisor of imu_rate_hz), linearly interpolated onto the
  // gyro's stamps, as hal/d455 fuses a D455's 100 Hz accel with its 200 Hz gyro; 0: imu_rate_hz.
  double accel_rate_hz = 0.0;
  // s, a camera-IMU time offset: images taken at IMU time t are stamped t - td_s (t_imu = t_cam +
  // td_s, the calibration's convention). The calibration written says 0, as a user would believe.
  double td_s = 0.0;
  // The calibration written has both cameras' T_b_c off the rendering's by a rotation of this
  // many degrees about an axis and a shift of this many metres in a direction, both drawn from the
  // seed: the rig mounted off against the IMU, the stereo baseline exact.
  double extrinsic_error_deg = 0.0;
  double extrinsic_error_m = 0.0;
  // kRealistic: both styles' IMU gets imu_errors (vibration, scale, misalignment, drift), none of
  // it in the sensor.yaml written (the datasheet's densities, as a user has them).
  ImuModel imu_model = ImuModel::kIdeal;
  ImuErrorOptions imu_errors;
  WorldOptions world;                 // procedural style's world
  StreetOptions street;               // car scenarios' world (its seed is set from seed)
  RenderOptions render;
  SimStyle style = SimStyle::kProcedural;
  // Photo style only (the procedural style ignores these):
  std::string texture_dataset;        // EuRoC dataset folder (holds mav0/) whose cam0/cam1 images
                                      // texture the world; required
  ExposureOptions exposure;           // exposure time (motion blur) and sub-exposure bounds
  double imu_internal_rate_hz = 2000.0;       // Hz, the IMU's rate before integration/decimation
  double initial_gyro_bias_max_rad_s = 0.08;  // initial gyro bias uniform in +-this per axis, rad/s
  double initial_accel_bias_max_m_s2 = 0.1;   // initial accel bias uniform in +-this per axis, m/s^2
  PhotoWorldOptions photo_world;      // (its seed and textureless_walls are set from seed, scenario)
  PhotoLensOptions lens;              // vignetting per camera, shot noise
  bool validate(std::string* error) const;
};

// A preset's sensor timing: EuRoC 20 Hz cameras, 200 Hz IMU; D455 30 Hz cameras, 200 Hz gyro,
// 100 Hz accelerometer (SimOptions::accel_rate_hz).
void apply_timing_preset(CameraPreset preset, SimOptions* options);

// The continuous body trajectory of a run and its time span [t_begin_ns, t_end_ns]. Camera
// poses and the IMU both come from it (spline for the procedural style, se3 for the photo style).
struct SimTrajectory {
  SimStyle style = SimStyle::kProcedural;
  PoseSpline spline;                  // procedural
  Se3Spline se3;                      // photo
  std::int64_t t_begin_ns = 0;
  std::int64_t t_end_ns = 0;
  std::int64_t flight_begin_ns = 0;   // end of the scenario prefix (== t_begin without one)

  Eigen::Isometry3d T_w_b(std::int64_t t_ns) const;  // body pose of the style's spline
};
SimTrajectory make_trajectory(const SimOptions& options, const RigCalibration& rig);

// The style's IMU: analytic derivatives (procedural) or generate_decimated_imu (photo).
ImuTrack generate_imu(const SimTrajectory& trajectory, const ImuCalibration& imu, const SimOptions& options);
// The calibration a run writes: `truth` with SimOptions' planted extrinsic error (identical to
// it without one).
RigCalibration written_calibration(const RigCalibration& truth, const SimOptions& options);

using ProgressCallback = std::function<void(int frames_done, int frames_total)>;

struct SimStats {
  int frames = 0;                 // stereo pairs written
  long sub_exposures = 0;         // renders per camera summed over frames (photo: >= frames)
  int max_sub_exposures = 0;      // most in one frame
};

// Writes the dataset to options.out_dir. Returns 0, or 1 with *error set (bad options, file
// errors). Also writes out_dir/sim_events.csv (header: scenario, seed, style; then scenario
// events: impulses, dark/dropout spans). stats (optional) receives the rendering counts.
int simulate(const SimOptions& options, std::string* error, const ProgressCallback& progress = {},
             SimStats* stats = nullptr);

}  // namespace ums::sim
