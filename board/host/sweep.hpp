#pragma once
// `umsvins sweep`: the paper's 30-run robustness table (Table-init of UMS-VINS.tex): replay one
// dataset N times from start times drawn uniformly in [A, B] s, score each run by ATE RMSE after
// SE(3) alignment to the dataset's ground truth, and report per-run RMSE, mean, standard deviation
// and failures (each with its reason).
//
// The loop takes the replay as a callback (SweepRunner) so a test can drive it with synthetic
// runs; the command (sweep_command.cpp) passes one that calls run_replay in-process.
// Tool code (start-up / offline): std::vector, std::string and exceptions are fine here.

#include <cstdint>
#include <functional>
#include <iosfwd>
#include <map>
#include <string>
#include <vector>

#include "profiling/eval/trajectory.hpp"

namespace ums::cli {

struct SweepOptions {
  std::string dataset;              // folder holding mav0/
  std::string out_dir;              // sweep.json and run_<k>/ go here
  int runs = 30;                    // N, >= 1
  double start_min_s = 0.0;         // s after the dataset's first frame: A of --start-range
  double start_max_s = 60.0;        // s: B of --start-range, >= A
  std::uint64_t seed = 1;           // of the start-time generator (std::mt19937_64)
  double duration_s = 0.0;          // s of data per run; 0 = to the end of the dataset
  std::string config_path;          // replay --config; empty = from the dataset's sensor.yaml
  double min_pose_fraction = 0.9;   // a run needs poses for at least this share of its frames

  // False with a message naming the option on a bad value.
  bool validate(std::string* error) const;
};

// What the runner saw of one replay (its files are read from run_dir afterwards).
struct RunOutcome {
  int exit_code = 0;     // replay's exit code (0 ok)
  std::string message;   // replay's error text when it failed (last line is enough)
};

// Runs one replay starting start_s seconds into the dataset, writing into run_dir.
using SweepRunner = std::function<RunOutcome(double start_s, const std::string& run_dir)>;

struct SweepRun {
  int run = 0;                // k, from 1
  double start_s = 0.0;       // s
  bool success = false;
  double rmse_m = -1.0;       // ATE RMSE after SE(3) alignment, m; < 0 when it could not be computed
  std::string reason;         // empty on success; every failed check otherwise, joined by "; "
  long frames = -1;           // stats.json `frames`; -1 when unknown
  long poses = 0;             // distinct poses in trajectory.tum
  bool init_success = false;  // stats.json `init.success`
};

struct SweepSummary {
  int runs = 0;
  int failures = 0;
  double rmse_mean_m = -1.0;  // mean over successful runs, m; < 0 when none succeeded
  double rmse_std_m = -1.0;   // SAMPLE standard deviation (n - 1) over successful runs, m;
                              // 0 for one success, < 0 for none
};

struct SweepResult {
  std::vector<SweepRun> runs;
  SweepSummary summary;
};

// N start times uniform in [a_s, b_s] from std::mt19937_64(seed); the same seed gives the same times
// on every platform (the 64-bit draws are mapped to [0, 1] by hand, not by a library distribution).
std::vector<double> draw_start_times(int n, double a_s, double b_s, std::uint64_t seed);

// Flattens a JSON document into "a.b.c" -> scalar text (strings unquoted and unescaped, arrays by
// index: "modes.0.t"). Throws std::runtime_error naming the byte offset on malformed text.
std::map<std::string, std::string> flatten_json(const std::string& text);

// Scores one finished run from the files in run_dir (trajectory.tum, stats.json) against the
// ground truth (body frame). Never throws: every problem becomes part of `reason`.
SweepRun score_run(int run, double start_s, const RunOutcome& outcome, const std::string& run_dir,
                   const eval::Trajectory& groundtruth, double min_pose_fraction);

SweepSummary summarize(const std::vector<SweepRun>& runs);

// The whole sweep: draws the start times, runs and scores each run (progress lines on `progress`).
SweepResult run_sweep_loop(const SweepOptions& options, const eval::Trajectory& groundtruth,
                           const SweepRunner& runner, std::ostream& progress);

// sweep.json: {"dataset", "seed", "start_range_s", "runs": [...], "summary": {...}}.
std::string sweep_json(const SweepOptions& options, const SweepResult& result);

// The table (run, start, RMSE, status) and the summary line.
void print_sweep_table(const SweepResult& result, std::ostream& out);

// <dataset>/mav0/state_groundtruth_estimate0/data.csv
std::string sweep_groundtruth_path(const std::string& dataset);

}  // namespace ums::cli
