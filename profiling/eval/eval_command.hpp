#pragma once
// Library side of `umsvins eval --estimate F --groundtruth F [--align se3|sim3|posyaw]
// [--stats stats.json] [--json F]`: reads both files, brings the estimate into the ground truth's
// frame (body -> cam0 with T_BS of cam0 when the ground truth is the shared *_GT.txt), associates,
// aligns and prints ATE, RPE and the error budget (error_budget.hpp); optionally the same as JSON.

#include <iosfwd>
#include <optional>
#include <string>

#include "profiling/eval/error_budget.hpp"
#include "profiling/eval/metrics.hpp"
#include "profiling/eval/mode_timeline.hpp"
#include "profiling/eval/trajectory.hpp"

namespace ums::eval {

struct EvalOptions {
  std::string estimate_path;                                // TUM by default (body frame)
  std::string groundtruth_path;                             // TUM, EuRoC csv or shared *_GT.txt
  TrajectoryFormat estimate_format = TrajectoryFormat::kAuto;
  TrajectoryFormat groundtruth_format = TrajectoryFormat::kAuto;
  AlignMode align = AlignMode::kSe3;
  // sensor.yaml whose T_BS is cam0 -> body; empty: EuRoC VI-Sensor cam0 (euroc_T_b_c0()).
  std::string cam0_sensor_yaml;
  double max_dt_s = 0.01;                                   // association tolerance, s
  double rpe_distances_m[3] = {1.0, 5.0, 10.0};             // m
  double rpe_times_s[3] = {1.0, 5.0, 10.0};                 // s
  // The replay's mode timeline (stats.json, read at the edge); absent: no per-mode split.
  std::optional<ModeTimeline> modes;
  BudgetOptions budget;                                     // anchor and window lengths, s
  std::string json_path;                                    // non-empty: also write eval.json here

  bool validate(std::string* error) const;
};

// Prints the report to `out`. Returns 0 on success, 1 on a usage/file error (message in *error).
// `result` and `budget` (optional) receive the numbers printed.
int run_eval(const EvalOptions& options, std::ostream& out, std::string* error,
             EvalResult* result = nullptr, ErrorBudget* budget = nullptr);

// Same, from already-loaded trajectories (the replay command's summary uses it).
EvalResult evaluate_frames(const Trajectory& estimate, const Trajectory& groundtruth,
                           const Eigen::Isometry3d& T_b_c0, const MetricsOptions& options);

void print_eval(const EvalResult& result, AlignMode align, std::ostream& out);

// The JSON document of --json: the figures print_eval prints plus "budget" (null when it could not
// be computed; keys in docs/evaluation.md). Throws std::runtime_error on I/O failure.
void write_eval_json(const std::string& path, const EvalOptions& options, const EvalResult& result,
                     const ErrorBudget* budget);

}  // namespace ums::eval
