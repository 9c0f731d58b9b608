#pragma once
// The estimator's counters and its mode log: what stats.json reports under init, modes,
// estimator, memory.pools and drops. Every part of the estimator counts into one of these.

#include <cstddef>
#include <cstdint>

#include "core/common/fixed_vector.hpp"
#include "core/estimator/mode_machine.hpp"

namespace ums {

struct ModeChange {
  std::int64_t t_ns = 0;
  EstimatorMode from = EstimatorMode::kImuOnly;
  EstimatorMode to = EstimatorMode::kImuOnly;
  const char* reason = "";        // static string
};

struct EstimatorStats {
  std::uint64_t frames = 0;
  std::uint64_t frames_in_mode[kEstimatorModes] = {0, 0, 0, 0};
  bool initialized = false;            // reached VIO
  std::int64_t first_frame_t_ns = -1;
  std::int64_t init_t_ns = -1;         // first time VIO was reached
  const char* init_case = "";          // "standstill" or "visual-imu alignment"
  FixedVector<ModeChange, 64> mode_changes;
  std::uint64_t mode_changes_dropped = 0;
  std::uint64_t visual_init_failures = 0;
  std::uint64_t align_attempts = 0;
  std::uint64_t align_failures = 0;     // any step of case 2 failed
  std::uint64_t align_unobservable = 0;   // refused: gravity's direction not known well enough
  double align_tilt_sigma_deg = -1.0;     // deg, of the last attempt that got that far
  std::uint64_t solves = 0;
  std::uint64_t problem_builds = 0;  // solves on a problem built anew (ProblemBuilder::solve_again may not)
  // Summed over the solves (solver::SolverSummary): LM step attempts, accepted steps, whole
  // linearizations (Jacobians and H), of them gradient-only passes, steps solved with the factor
  // of the step before, and sweeps over the residuals of every kind.
  std::uint64_t solver_iterations = 0;
  std::uint64_t solver_successful_steps = 0;
  std::uint64_t solver_linearizations = 0;
  std::uint64_t solver_gradient_passes = 0;
  std::uint64_t solver_factor_reuses = 0;
  std::uint64_t solver_residual_passes = 0;
  std::uint64_t stage_kept_2d_left = 0;   // 3D vs 3D+2D-left agreed
  std::uint64_t stage_added_2d_right = 0; // disagreed or too few 3D: all classes
  std::uint64_t stage_3d_sufficient = 0;  // no 2D-left landmark to try: one stage
  std::uint64_t stage_few_2d_left = 0;    // fewer than stage_min_2d_left: one solve with them
  std::uint64_t outlier_landmarks = 0;
  std::uint64_t second_rounds = 0;        // frames whose round 2 ran (enough outliers or not converged)
  std::uint64_t second_rounds_skipped = 0;  // frames whose outliers were too few for a round 2
  std::uint64_t second_round_rebuilds = 0;  // of them, problems built again for the marginalization
  std::uint64_t outliers_into_prior = 0;    // landmarks marked as outliers marginalized into the prior (0)
  std::uint64_t marginalized_old = 0;
  std::uint64_t marginalized_second_new = 0;
  std::uint64_t marginalization_failures = 0;
  std::uint64_t marginalizations_reused = 0;  // of marginalized_old: the solve's landmark terms taken
  std::uint64_t still_frames = 0;
  std::uint64_t still_rejected_by_vision = 0;  // IMU at rest but the images moved (uniform motion)
  std::uint64_t resets = 0;             // divergence or visual loss in VO
  std::uint64_t relevels = 0;           // VIO entered: the window re-levelled to gravity
  double sum_landmarks_in_solve = 0.0;
  double sum_2d_in_solve = 0.0;         // 2D-left + 2D-right landmarks in the final solves
  std::uint64_t frames_solved = 0;
  std::size_t peak_landmarks = 0;       // landmark pool use
  std::size_t peak_residuals = 0;       // visual residual objects
  std::uint64_t drops_landmarks = 0;    // features not tracked: landmark pool full
  std::uint64_t drops_residuals = 0;    // observations not used: residual pool full
  std::uint64_t drops_imu = 0;          // IMU samples not integrated: interval buffer full
  std::uint64_t imu_out_of_order = 0;
  std::uint64_t imu_gap_frames = 0;       // frames whose IMU interval spans a hole (imu_max_gap_ms)
  std::uint64_t imu_held = 0;             // saturated samples replaced by the previous one
  std::uint64_t frames_out_of_order = 0;  // frames not after the previous one: not processed
  std::uint64_t keyframes_emitted = 0;    // keyframes handed to the KeyframeSink
  std::uint64_t frames_without_pose = 0;  // IMU_ONLY before the velocity was ever known
  // Tightly coupled relocation (relocation.hpp).
  std::uint64_t relocation_requests = 0;   // taken from the loop closer
  std::uint64_t relocations_solved = 0;    // with the loop keyframe's pose in the solve
  std::uint64_t relocation_residuals = 0;  // summed over those
  // estimate_extrinsic: when the extrinsics were first released (-1: never), and the largest rotation
  // excitation of the window seen before, deg.
  std::int64_t extrinsic_released_t_ns = -1;
  double max_rotation_excitation_deg = 0.0;
  std::uint64_t td_clamped = 0;  // estimate_td: VIO solves whose offset left td_max_change_ms
  std::uint64_t gyro_scale_clamped = 0;  // estimate_gyro_scale: VIO solves beyond gyro_scale_max_pct
};

}  // namespace ums
