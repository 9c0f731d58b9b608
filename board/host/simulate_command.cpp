// umsvins simulate: a synthetic stereo + IMU dataset in the EuRoC layout (hal/sim).

#include "board/host/cli_args.hpp"
#include "board/host/commands.hpp"
#include "hal/sim/simulate.hpp"
#include "profiling/progress.hpp"

namespace ums::cli {

int run_simulate(const std::vector<std::string>& argv, std::ostream& out, std::ostream& err) {
  const Args args("simulate", argv, {"exposure-change", "quiet"},
                  {"trajectory", "scenario", "seed", "out", "duration", "start", "camera", "max-frames"});
  args.require_positionals(0, "");
  sim::SimOptions options;
  options.out_dir = args.require("out");
  options.trajectory_path = args.get_or("trajectory", "");
  const std::string scenario = args.get_or("scenario", "nominal");
  if (!sim::parse_scenario(scenario, &options.scenario)) {
    throw UsageError("umsvins simulate: unknown --scenario '" + scenario +
                     "' (nominal, standstill-start, uniform-start, dark-start, textureless, impulses, "
                     "right-dropout)");
  }
  const std::string camera = args.get_or("camera", "euroc");
  if (!sim::parse_camera_preset(camera, &options.camera_preset)) {
    throw UsageError("umsvins simulate: unknown --camera '" + camera + "' (euroc, d455)");
  }
  const long seed = args.get_long("seed", 1);
  if (seed < 0) throw UsageError("umsvins simulate: --seed must be >= 0");
  options.seed = static_cast<std::uint64_t>(seed);
  options.duration_s = args.get_double("duration", options.duration_s);
  options.start_s = args.get_double("start", 0.0);
  options.max_frames = static_cast<int>(args.get_long("max-frames", -1));
  options.exposure_change = args.has("exposure-change");

  std::string error;
  if (!options.validate(&error)) throw UsageError("umsvins simulate: " + error);
  Progress progress("simulate", 0);
  const bool quiet = args.has("quiet");
  const int rc = sim::simulate(options, &error, [&](int done, int total) {
    if (quiet) return;
    static_cast<void>(total);
    progress.update(static_cast<unsigned long>(done));
  });
  if (!quiet) progress.finish();
  if (rc != 0) {
    err << "umsvins simulate: " << error << "\n";
    return kExitFailure;
  }
  out << "simulate: " << sim::scenario_name(options.scenario) << " dataset written to " << options.out_dir
      << " (seed " << options.seed << ")\n";
  return kExitOk;
}

}  // namespace ums::cli
