// umsvins eval: ATE, RPE and the error budget of an estimate against ground truth (profiling/eval).

#include <fstream>
#include <sstream>

#include "board/host/cli_args.hpp"
#include "board/host/commands.hpp"
#include "board/host/sweep.hpp"  // flatten_json: the reader of our own stats.json
#include "profiling/eval/eval_command.hpp"

namespace ums::cli {
namespace {

// The mode timeline of a replay's stats.json; throws UsageError naming the file.
eval::ModeTimeline read_mode_timeline(const std::string& path) {
  std::ifstream f(path);
  if (!f) throw UsageError("umsvins eval: --stats " + path + ": cannot open");
  std::stringstream text;
  text << f.rdbuf();
  eval::ModeTimeline timeline;
  std::string error;
  try {
    if (eval::mode_timeline_from_stats(flatten_json(text.str()), &timeline, &error)) return timeline;
  } catch (const std::runtime_error& e) {
    error = e.what();
  }
  throw UsageError("umsvins eval: --stats " + path + ": " + error);
}

}  // namespace

int run_eval(const std::vector<std::string>& argv, std::ostream& out, std::ostream& err) {
  const Args args("eval", argv, {},
                  {"estimate", "groundtruth", "align", "cam0-sensor-yaml", "max-dt", "stats", "json"});
  args.require_positionals(0, "");
  eval::EvalOptions options;
  options.estimate_path = args.require("estimate");
  options.groundtruth_path = args.require("groundtruth");
  const std::string align = args.get_or("align", "se3");
  if (!eval::parse_align_mode(align, &options.align)) {
    throw UsageError("umsvins eval: --align must be se3, sim3 or posyaw, got '" + align + "'");
  }
  options.cam0_sensor_yaml = args.get_or("cam0-sensor-yaml", "");
  options.max_dt_s = args.get_double("max-dt", options.max_dt_s);
  if (const auto stats = args.get("stats")) options.modes = read_mode_timeline(*stats);
  options.json_path = args.get_or("json", "");
  std::string error;
  if (!options.validate(&error)) throw UsageError("umsvins eval: " + error);
  const int rc = eval::run_eval(options, out, &error);
  if (rc != 0) {
    err << "umsvins eval: " << error << "\n";
    return kExitFailure;
  }
  return kExitOk;
}

}  // namespace ums::cli
