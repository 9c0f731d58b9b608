#pragma once
// Initialization (paper Sec. III-B): the standstill test (IMU at rest and the images agree), the
// standstill initialization (gravity, zero velocity and gyro bias from the rest), the visual
// initialization step (PnP, triangulation, vision-only BA) and the case-2 visual-IMU alignment.
// Each returns what happened as a ModeEvent; the estimator's transition function decides the
// mode. On a failed alignment the window's VO state is restored.

#include <cstdint>
#include <memory>

#include <Eigen/Core>

#include "core/common/calibration.hpp"
#include "core/estimator/estimator_options.hpp"
#include "core/estimator/mode_machine.hpp"
#include "core/imu/standstill.hpp"

namespace ums {

class Window;
class LandmarkMap;
class ProblemBuilder;
class Marginalizer;
class ImuBuffer;
class PnpLocator;
struct WindowBackup;
struct EstimatorStats;

class Initializer {
 public:
  Initializer(const EstimatorOptions& options, const RigCalibration& rig, Window* window, LandmarkMap* landmarks,
              ProblemBuilder* builder, Marginalizer* marginalizer, EstimatorStats* stats);
  ~Initializer();
  Initializer(const Initializer&) = delete;
  Initializer& operator=(const Initializer&) = delete;

  // IMU at rest over the last standstill_window_s before t_ns (a shorter window is not trusted).
  bool imu_at_rest(std::int64_t t_ns, ImuBuffer* imu, StandstillResult* result) const;
  // Mean de-rotated image motion of the left features between two window slots (px); -1 when
  // fewer than 10 are shared. The IMU cannot tell rest from uniform motion: the images can.
  float visual_flow_px(int prev_slot, int slot, const Eigen::Vector3d& bg) const;

  // Stereo visual initialization of the newest frame: PnP against the window, triangulation,
  // vision-only BA. False: PnP failed (the caller restarts the window).
  bool visual_step(PnpLocator* pnp);
  // At rest the accelerometer measures gravity and the gyro its bias: kStandstill.
  ModeEvent standstill(const StandstillResult& rest);
  // Case 2: IMU initialization, the observability test, then the loosely coupled BA; kAlignment
  // or kNone (the VO state restored).
  ModeEvent align();

 private:
  bool imu_initialization(Eigen::Vector3d* bg);
  bool observable();  // gravity's direction known to align_max_tilt_sigma_deg
  ModeEvent fail(bool unobservable);
  bool vision_only_ba(int iterations);

  EstimatorOptions options_;
  ImuNoise noise_;                 // calibrated (not inflated): the standstill thresholds
  Eigen::Vector3d g_w_;
  Window* window_;
  LandmarkMap* landmarks_;
  ProblemBuilder* builder_;
  Marginalizer* marginalizer_;
  EstimatorStats* stats_;
  std::unique_ptr<WindowBackup> vo_state_;
};

}  // namespace ums
