// umsvins eval: ATE and RPE of an estimate against ground truth (profiling/eval).

#include "board/host/cli_args.hpp"
#include "board/host/commands.hpp"
#include "profiling/eval/eval_command.hpp"

namespace ums::cli {

int run_eval(const std::vector<std::string>& argv, std::ostream& out, std::ostream& err) {
  const Args args("eval", argv, {}, {"estimate", "groundtruth", "align", "cam0-sensor-yaml", "max-dt"});
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
