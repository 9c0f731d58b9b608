// umsvins sweep: replay one dataset from N random start times and tabulate the ATE RMSE of each
// run (the paper's 30-run robustness table). The loop and the scoring are in sweep.hpp; this file
// parses the command line and runs each replay in-process.

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <sstream>

#include "board/host/cli_args.hpp"
#include "board/host/commands.hpp"
#include "board/host/sweep.hpp"
#include "profiling/eval/trajectory.hpp"

namespace ums::cli {
namespace {

std::string last_line(const std::string& text) {
  std::istringstream in(text);
  std::string line;
  std::string last;
  while (std::getline(in, line)) {
    if (!line.empty()) last = line;
  }
  return last;
}

std::string seconds_text(double s) {
  char buf[64];
  std::snprintf(buf, sizeof buf, "%.9f", s);
  return buf;
}

}  // namespace

int run_sweep(const std::vector<std::string>& argv, std::ostream& out, std::ostream& err) {
  const Args args("sweep", argv, {}, {"runs", "start-range", "out", "seed", "duration", "config"});
  args.require_positionals(1, "<dataset> (the folder holding mav0/)");
  SweepOptions options;
  options.dataset = args.positionals()[0];
  options.out_dir = args.require("out");
  const long runs = args.get_long("runs", 0);
  if (!args.has("runs")) throw UsageError("umsvins sweep: --runs is required (the paper uses 30)");
  if (runs < 1 || runs > 100000) {
    throw UsageError("umsvins sweep: --runs must be between 1 and 100000, got " + std::to_string(runs));
  }
  options.runs = static_cast<int>(runs);
  if (!args.has("start-range")) {
    throw UsageError("umsvins sweep: --start-range A:B is required (seconds; the paper uses 0:60)");
  }
  const std::pair<double, double> range = args.get_range("start-range", {0.0, 0.0});
  options.start_min_s = range.first;
  options.start_max_s = range.second;
  const long seed = args.get_long("seed", 1);
  if (seed < 0) throw UsageError("umsvins sweep: --seed must be >= 0, got " + std::to_string(seed));
  options.seed = static_cast<std::uint64_t>(seed);
  options.duration_s = args.get_double("duration", 0.0);
  options.config_path = args.get_or("config", "");
  std::string error;
  if (!options.validate(&error)) throw UsageError("umsvins sweep: " + error);
  if (!std::filesystem::is_directory(std::filesystem::path(options.dataset) / "mav0")) {
    throw UsageError("umsvins sweep: '" + options.dataset + "' is not a dataset (no mav0/ folder in it)");
  }

  // The score needs the dataset's own ground truth; without it there is nothing to tabulate.
  const std::string gt_path = sweep_groundtruth_path(options.dataset);
  if (!std::filesystem::exists(gt_path)) {
    err << "umsvins sweep: " << gt_path << ": no ground truth, the runs cannot be scored\n";
    return kExitFailure;
  }
  const eval::Trajectory groundtruth = eval::read_euroc_csv(gt_path);  // throws with file:line

  const SweepRunner replay = [&options](double start_s, const std::string& run_dir) {
    std::vector<std::string> replay_args{options.dataset, "--out", run_dir, "--start", seconds_text(start_s),
                                         "--quiet"};
    if (options.duration_s > 0.0) {
      replay_args.push_back("--duration");
      replay_args.push_back(seconds_text(options.duration_s));
    }
    if (!options.config_path.empty()) {
      replay_args.push_back("--config");
      replay_args.push_back(options.config_path);
    }
    std::ostringstream replay_out;
    std::ostringstream replay_err;
    RunOutcome outcome;
    try {
      outcome.exit_code = run_replay(replay_args, replay_out, replay_err);
    } catch (const UsageError& e) {
      outcome.exit_code = kExitUsage;
      outcome.message = e.what();
    } catch (const std::exception& e) {
      outcome.exit_code = kExitFailure;
      outcome.message = e.what();
    }
    if (outcome.exit_code != 0 && outcome.message.empty()) outcome.message = last_line(replay_err.str());
    // What replay said, kept beside its files for whoever looks into a failed run.
    std::ofstream log(std::filesystem::path(run_dir) / "replay.log");
    log << replay_out.str() << replay_err.str();
    if (!outcome.message.empty()) log << outcome.message << "\n";
    return outcome;
  };

  const SweepResult result = run_sweep_loop(options, groundtruth, replay, err);

  const std::filesystem::path json_path = std::filesystem::path(options.out_dir) / "sweep.json";
  std::ofstream json(json_path);
  json << sweep_json(options, result);
  if (!json) {
    err << "umsvins sweep: " << json_path.string() << ": write failed\n";
    return kExitFailure;
  }
  print_sweep_table(result, out);
  out << "sweep: wrote " << json_path.string() << "\n";
  // Failed runs are results (listed above); only a sweep with no successful run has no statistic.
  return result.summary.failures < result.summary.runs ? kExitOk : kExitFailure;
}

}  // namespace ums::cli
