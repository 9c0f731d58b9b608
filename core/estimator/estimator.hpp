#pragma once
// The estimator of the paper (Sec. III-B, III-C): a mode machine over a sliding window.
//
//   IMU_ONLY  case 1: no visual initialization yet (too few 3D features, e.g. dark images) or
//             vision lost: the pose comes from IMU propagation, attitude from gravity at rest or
//             the last estimate; zero velocity while the IMU says the rig is still.
//   VO        case 2 in progress or failed: stereo visual initialization succeeded (PnP with
//             RANSAC on bearings, then BA of poses and inverse depths); the window runs stereo +
//             2D features without the IMU while the visual-IMU alignment is retried.
//   VIO       case 3: aligned. Each frame: IMU prediction, the tightly coupled BA of eq. (4)
//             with the two-stage feature use, outlier removal, a second time-bounded round, then
//             marginalization (oldest when the new frame is a keyframe, else the second newest).
// Alignment (case 2): gyro bias from relative rotations, gravity and velocities by least squares
// (stereo fixes the scale), then an observability test (the window must know gravity's direction,
// or the accelerometer must be excited; uniform motion is neither and stays in VO), then the
// loosely coupled BA. At rest the IMU gives
// gravity, zero velocity and the gyro bias directly (standstill start: initialized at once).
//
// The Estimator orchestrates narrow parts (docs/estimator.md): Window (frames by FrameId, the
// extrinsics), ImuBuffer, LandmarkMap, ProblemBuilder (the only residual wiring), Initializer,
// PnpLocator, Marginalizer (prior + keyframe outlet), the mode transition function and the
// odometry frame of the output. Fixed memory: every part allocates in the constructor;
// add_imu / add_frame allocate nothing.

#include <chrono>
#include <cstdint>
#include <memory>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "core/common/calibration.hpp"
#include "core/common/capacity.hpp"
#include "core/common/imu_sample.hpp"
#include "core/estimator/estimator_options.hpp"
#include "core/estimator/estimator_stats.hpp"
#include "core/estimator/frame_id.hpp"
#include "core/estimator/keyframe_sink.hpp"
#include "core/estimator/landmark.hpp"
#include "core/estimator/mode_machine.hpp"
#include "core/estimator/odometry_frame.hpp"
#include "core/estimator/relocation.hpp"
#include "core/frontend/frame_features.hpp"
#include "core/frontend/keyframe_selector.hpp"
#include "core/imu/propagation.hpp"
#include "core/imu/standstill.hpp"

namespace ums {

class Window;
struct WindowFrame;
class ImuBuffer;
class LandmarkMap;
class Marginalizer;
class ProblemBuilder;
class Initializer;
class PnpLocator;
struct WindowBackup;
struct SolveSpec;
struct SolveBudget;

// The estimate at one frame (camera rate).
struct EstimatorOutput {
  std::int64_t t_ns = 0;             // frame time (the pipeline clock: IMU clock)
  FrameId frame_id = kNoFrame;       // the window frame this estimate belongs to
  EstimatorMode mode = EstimatorMode::kImuOnly;
  bool valid = false;                // a pose exists (attitude and velocity known)
  bool keyframe = false;
  // T_w_b = T_w_odom * T_odom_b (odometry_frame.hpp).
  Eigen::Vector3d p_w_b = Eigen::Vector3d::Zero();            // m
  Eigen::Quaterniond q_w_b = Eigen::Quaterniond::Identity();  // x,y,z,w in memory
  Eigen::Vector3d v_w_b = Eigen::Vector3d::Zero();            // m/s
  Eigen::Vector3d ba = Eigen::Vector3d::Zero();               // m/s^2
  Eigen::Vector3d bg = Eigen::Vector3d::Zero();               // rad/s
  int landmarks_in_solve = 0;
  int n_3d_used = 0, n_2d_left_used = 0, n_2d_right_used = 0;  // landmarks of each class solved
  bool still = false;                // the IMU said: at rest
  double td_s = 0.0;                 // s, the camera-IMU offset in use (estimated with estimate_td)
  // Output discontinuities so far: restarts (divergence, vision lost), re-levelling of the world
  // (entering VIO) and moves of the odometry frame. A consumer that fuses the pose (a flight
  // controller: MAVLink reset_counter) resets its reference when this changes.
  std::uint32_t reset_counter = 0;
  // The odometry frame's epoch (MarginalizedKeyframe::odometry_epoch): resets and re-levellings
  // only, not the world placements that reset_counter also counts.
  std::uint32_t odometry_epoch = 0;
  // The frame this frame's window slide made permanent: it stays until it leaves as the oldest
  // (then it reaches the KeyframeSink). It is the previous frame when this one is a keyframe or
  // the window was not yet full (VINS's rule: a non-keyframe replaces the second newest), else
  // kNoFrame. A keyframe database describes that frame's image, not this one's.
  FrameId settled_frame = kNoFrame;
};

// Wall time of the back-end stages of one frame (ms).
struct EstimatorTiming {
  float preintegrate_ms = 0.0f;   // closing the interval, whitening, standstill test
  float solve_round1_ms = 0.0f;   // the stage solves (3D / 3D+2D-left / all)
  float solve_round2_ms = 0.0f;   // after outlier removal, time-bounded
  float marginalize_ms = 0.0f;
  float backend_ms = 0.0f;        // the whole add_frame
};

class Estimator {
 public:
  // Start-up: validates options (std::invalid_argument), allocates every buffer.
  Estimator(const EstimatorOptions& options, const RigCalibration& rig);
  ~Estimator();
  Estimator(const Estimator&) = delete;
  Estimator& operator=(const Estimator&) = delete;

  // One IMU sample (time-ordered, after the saturation element; saturated: the element clipped
  // it, the previous sample is held instead). Allocates nothing.
  void add_imu(const ImuSample& sample, bool saturated = false);
  // Time passed after the last sample that no stamp shows (samples dropped because the clock
  // stepped back): the interval it falls in is widened as across a hole of that length.
  void note_lost_imu_time(std::int64_t lost_ns);
  // One frame of features (stamp in the IMU clock: the pipeline applies the time offset);
  // writes the optimized pose at this frame. Allocates nothing.
  void add_frame(const FrameFeatures& features, EstimatorOutput* out, EstimatorTiming* timing);

  EstimatorMode mode() const { return mode_; }
  const EstimatorStats& stats() const { return stats_; }
  const EstimatorOptions& options() const { return options_; }  // as validated and prepared
  // The IMU-rate pose: the last frame's estimate propagated with every sample since.
  bool imu_rate_state(NavState* state) const;
  // Where keyframes leaving the window go (nullptr: nowhere); the sink outlives the estimator.
  void set_keyframe_sink(KeyframeSink* sink);
  // Where tightly coupled relocations come from and their results go (nullptr: none); called on
  // this thread, outlives the estimator.
  void set_relocation_link(RelocationLink* link) { relocation_link_ = link; }
  OdometryFrame& odometry_frame() { return odom_; }
  const OdometryFrame& odometry_frame() const { return odom_; }
  const Window& window() const { return *window_; }
  // Static footprint of this object and what it owns (bytes), for `umsvins budget`.
  std::size_t footprint_bytes() const;
  std::size_t landmark_capacity() const { return capacity::kMaxLandmarks; }
  std::size_t landmarks_in_use() const;

 private:
  static double ms_since(std::chrono::steady_clock::time_point t0);

  // Steps of add_frame.
  bool out_of_order(const FrameFeatures& ff, EstimatorOutput* out);
  StandstillResult begin_frame(const FrameFeatures& ff, WindowFrame& f);
  void widen_imu_factor_over_hole(WindowFrame& f);
  Preintegration::UnmodelledMotion motion_claimed_over_hole(const WindowFrame& f, double hole_s) const;
  void initial_state(WindowFrame& f, const StandstillResult& rest);
  Eigen::Matrix3d c0_from_c1() const;  // right camera to left, from the current extrinsics
  // The cameras' rotation and rates from the gyro between the window frame before f and f (for
  // the bearing rates of estimate_td); not valid without two frames' IMU samples.
  CameraMotion camera_motion(const WindowFrame& prev, const WindowFrame& f) const;
  void observe(const FrameFeatures& ff, WindowFrame& f, const StandstillResult& rest);
  void run_mode(WindowFrame& f, EstimatorTiming* timing);
  void guard_divergence(WindowFrame& f);
  void write_output(const FrameFeatures& ff, const WindowFrame& f, EstimatorOutput* out);
  void end_frame(const WindowFrame& f, EstimatorTiming* timing);

  // Per mode (estimator_modes.cpp); each reports what happened.
  ModeEvent frame_imu_only(WindowFrame& f);
  ModeEvent frame_vo(WindowFrame& f);
  void frame_vio(WindowFrame& f, EstimatorTiming* timing);
  void hold_gauge(const Eigen::Isometry3d& T_w_b0_before);
  // The first-round solves' budget for frame f (max_steps_stage, unless f is an exempt keyframe).
  SolveBudget round1_budget(const WindowFrame& f) const;
  bool solve_stages(WindowFrame& f, SolveSpec* spec);
  void second_round(const SolveSpec& spec, bool converged);
  bool begin_relocation();
  // estimate_extrinsic: releases the extrinsics once the window is excited enough (sticky).
  void release_extrinsics_when_excited(std::int64_t t_ns);
  // The window's rotation about its least-excited axis: sqrt of the least eigenvalue of
  // sum phi phi^T over the rotations phi between consecutive frames, deg. Turning about one axis
  // only (a car) it stays 0: the extrinsic rotation about the others is not observable then.
  double rotation_excitation_deg() const;
  void end_relocation(const Eigen::Isometry3d& T_b0_loop, const SolveSpec& spec);
  void apply(ModeEvent event);

  // Window upkeep.
  void remove_frame(int pos);
  void reset_window(bool keep_newest);
  // VIO's window with the IMU in it (VIO, or VISION_LOST: the same window, nothing tracked).
  bool inertial_window() const { return mode_ == EstimatorMode::kVio || mode_ == EstimatorMode::kVisionLost; }
  ModeEvent watch_tracking(const WindowFrame& f);
  void slide_window(EstimatorTiming* timing);
  void merge_into_newest(WindowFrame& second, WindowFrame& newest);
  void set_nav_from(const WindowFrame& f);

  EstimatorOptions options_;
  RigCalibration rig_;
  Eigen::Vector3d g_w_;
  EstimatorMode mode_ = EstimatorMode::kImuOnly;
  bool tracking_ok_ = true;             // the newest frame tracked min_tracked_landmarks
  std::int64_t tracking_since_ns_ = 0;  // since when tracking_ok_ has held
  EstimatorStats stats_;
  KeyframeSelector keyframes_;

  std::unique_ptr<Window> window_;
  std::unique_ptr<ImuBuffer> imu_;
  std::unique_ptr<LandmarkMap> landmarks_;
  std::unique_ptr<Marginalizer> marginalizer_;
  std::unique_ptr<ProblemBuilder> builder_;
  std::unique_ptr<Initializer> initializer_;
  std::unique_ptr<PnpLocator> pnp_;
  std::unique_ptr<WindowBackup> stage_backup_;
  RelocationLink* relocation_link_ = nullptr;
  std::unique_ptr<RelocationRequest> relocation_;  // the one being solved

  ImuPropagator nav_;            // odometry frame
  OdometryFrame odom_;
  bool attitude_known_ = false;
  bool velocity_known_ = false;  // at rest once, or estimated by VO/VIO since the start
  StandstillResult last_still_;
  bool last_still_valid_ = false;
  int frames_since_align_ = 0;
  Eigen::Vector3d vo_velocity_ = Eigen::Vector3d::Zero();
  NavState last_odom_;           // the last output's state in the odometry frame (divergence fallback)
  EstimatorOutput last_output_;
  FrameId settled_ = kNoFrame;  // this frame's slide made it permanent (EstimatorOutput::settled_frame)
};

}  // namespace ums
