#pragma once
// Error budget of one flight: splits the error so the next bottleneck is visible (docs/evaluation.md
// "Error budget" defines every figure).
//  - ATE per estimator mode (IMU_ONLY, VO, VIO) under the one global SE(3) alignment, so that
//    ATE^2 = sum over modes of (poses_m / N) * rmse_m^2;
//  - scale error from the Sim(3) alignment;
//  - yaw drift and final position drift against an anchor fitted on the first anchor_s seconds;
//  - the worst window_s-long window of position error, and the mode it was flown in.
// Estimate and ground truth must place the same frame (trajectory.hpp change_frame). Tool code.

#include <cstdint>
#include <iosfwd>
#include <string>
#include <vector>

#include "profiling/eval/mode_timeline.hpp"
#include "profiling/eval/trajectory.hpp"

namespace ums {
class JsonWriter;
}

namespace ums::eval {

struct BudgetOptions {
  std::int64_t max_dt_ns = 10'000'000;  // association tolerance, ns
  double anchor_s = 10.0;               // s of estimate the drift anchor is fitted on
  double window_s = 5.0;                // s, length of the worst window
};

struct PhaseError {
  std::string mode;             // "IMU_ONLY", "VO", "VIO", "VISION_LOST", ...
  std::size_t poses = 0;        // matched poses estimated in this mode
  double duration_s = 0.0;      // s in this mode between the first and last matched pose
  double ate_rmse_m = 0.0;      // m, RMSE over those poses under the global SE(3); NaN if none
  double share_of_ate2 = 0.0;   // poses * rmse^2 / (N * ATE^2): this mode's part of ATE^2, 0..1
};

struct WorstWindow {
  bool found = false;           // false when the flight is shorter than the window
  double start_s = 0.0;         // s since the budget's origin (first pose of the window)
  double end_s = 0.0;           // s, start_s + window length
  std::int64_t start_t_ns = 0;  // absolute stamp of the window's first pose
  double rmse_m = 0.0;          // m, position RMSE over the window's poses (global SE(3))
  std::size_t poses = 0;
  std::string mode;             // mode of most of the window's poses; "" without a timeline
  double mode_share = 0.0;      // fraction of the window's poses in that mode, 0..1
};

struct ErrorBudget {
  // Time origin of every *_s below and of t_s: the timeline's origin (the run's first frame) when
  // known, else the first matched estimate pose.
  std::int64_t origin_t_ns = 0;
  bool origin_is_first_frame = false;
  std::size_t poses = 0;                   // matched poses N
  double duration_s = 0.0;                 // s, first to last matched pose
  double ate_rmse_m = 0.0;                 // m, whole flight, global SE(3) (= ATE of --align se3)
  bool has_phases = false;                 // false: no mode timeline given
  std::vector<PhaseError> phases;          // known modes first (IMU_ONLY, VO, VIO), then others
  double sim3_scale = 1.0;                 // s of the Sim(3) alignment (maps estimate to truth)
  double scale_error_pct = 0.0;            // %, 100 (1/s - 1): > 0 the estimate overstates distances
  double anchor_s = 0.0;                   // s actually used for the anchor (<= options.anchor_s)
  double yaw_error_end_deg = 0.0;          // deg, yaw error of the last pose against the anchor
  double yaw_drift_deg_per_min = 0.0;      // deg/min, least-squares slope of the yaw error
  double final_drift_m = 0.0;              // m, position error of the last pose against the anchor
  double distance_m = 0.0;                 // m, ground-truth path length over the matched poses
  double final_drift_pct = 0.0;            // %, 100 final_drift_m / distance_m; NaN if no motion
  double window_s = 0.0;                   // s, worst-window length
  WorstWindow worst;
  std::vector<double> t_s;                 // per matched pose: s since origin_t_ns
  std::vector<double> error_m;             // per matched pose: m, under the global SE(3)
};

// timeline may be null (no phase split). Throws std::runtime_error when fewer than 3 poses match
// or the frames differ.
ErrorBudget compute_error_budget(const Trajectory& est, const Trajectory& gt, const ModeTimeline* timeline,
                                 const BudgetOptions& options);

// The text block `umsvins eval` prints after ATE/RPE.
void print_error_budget(const ErrorBudget& budget, std::ostream& out);

// The "budget" object of eval.json (and of stats.json's accuracy), written at the writer's
// current position: keys in docs/evaluation.md.
void write_error_budget_json(const ErrorBudget& budget, JsonWriter& w);

}  // namespace ums::eval
