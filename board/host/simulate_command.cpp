// umsvins simulate: a synthetic stereo + IMU dataset in the EuRoC layout (hal/sim).

#include "board/host/cli_args.hpp"
#include "board/host/commands.hpp"
#include "hal/sim/simulate.hpp"
#include "profiling/progress.hpp"

namespace ums::cli {

int run_simulate(const std::vector<std::string>& argv, std::ostream& out, std::ostream& err) {
  const Args args("simulate", argv, {"exposure-change", "quiet"},
                  {"trajectory", "scenario", "seed", "out", "duration", "start", "camera", "max-frames", "style",
                   "texture-dataset", "exposure-ms", "blackout-s", "td-ms", "extrinsic-error-deg", "extrinsic-error-mm",
                   "imu-model", "imu-errors"});
  args.require_positionals(0, "");
  sim::SimOptions options;
  options.out_dir = args.require("out");
  options.trajectory_path = args.get_or("trajectory", "");
  const std::string scenario = args.get_or("scenario", "nominal");
  if (!sim::parse_scenario(scenario, &options.scenario)) {
    throw UsageError("umsvins simulate: unknown --scenario '" + scenario +
                     "' (nominal, standstill-start, uniform-start, dark-start, textureless, impulses, "
                     "right-dropout, blackout, car-turn, car-loop)");
  }
  const std::string camera = args.get_or("camera", "euroc");
  if (!sim::parse_camera_preset(camera, &options.camera_preset)) {
    throw UsageError("umsvins simulate: unknown --camera '" + camera + "' (euroc, d455)");
  }
  sim::apply_timing_preset(options.camera_preset, &options);
  const long seed = args.get_long("seed", 1);
  if (seed < 0) throw UsageError("umsvins simulate: --seed must be >= 0");
  options.seed = static_cast<std::uint64_t>(seed);
  options.duration_s = args.get_double("duration", options.duration_s);
  options.start_s = args.get_double("start", 0.0);
  options.max_frames = static_cast<int>(args.get_long("max-frames", -1));
  options.exposure_change = args.has("exposure-change");
  const std::string style = args.get_or("style", "procedural");
  if (!sim::parse_style(style, &options.style)) {
    throw UsageError("umsvins simulate: unknown --style '" + style + "' (procedural, photo)");
  }
  options.texture_dataset = args.get_or("texture-dataset", "");
  options.exposure.exposure_ms = args.get_double("exposure-ms", options.exposure.exposure_ms);
  options.blackout_s = args.get_double("blackout-s", options.blackout_s);
  options.td_s = args.get_double("td-ms", 0.0) * 1e-3;
  options.extrinsic_error_deg = args.get_double("extrinsic-error-deg", 0.0);
  options.extrinsic_error_m = args.get_double("extrinsic-error-mm", 0.0) * 1e-3;
  const std::string imu_model = args.get_or("imu-model", "ideal");
  if (!sim::parse_imu_model(imu_model, &options.imu_model)) {
    throw UsageError("umsvins simulate: unknown --imu-model '" + imu_model + "' (ideal, realistic)");
  }
  const std::string imu_errors = args.get_or("imu-errors", "all");
  if (!sim::select_imu_errors(imu_errors, &options.imu_errors)) {
    throw UsageError("umsvins simulate: unknown name in --imu-errors '" + imu_errors +
                     "' (comma-separated: vibration, scale, misalignment, drift; or all)");
  }
  if (options.style == sim::SimStyle::kPhoto && options.texture_dataset.empty()) {
    // A failure (exit 1), not a usage slip: the photo style cannot run without real images.
    err << "umsvins simulate: --style photo needs --texture-dataset DIR (an EuRoC dataset folder holding "
           "mav0/cam0/data and mav0/cam1/data, e.g. ../shared/data/euroc/V1_01_easy_micro)\n";
    return kExitFailure;
  }

  std::string error;
  if (!options.validate(&error)) throw UsageError("umsvins simulate: " + error);
  Progress progress("simulate", 0);
  const bool quiet = args.has("quiet");
  sim::SimStats stats;
  const int rc = sim::simulate(
      options, &error,
      [&](int done, int total) {
        if (quiet) return;
        static_cast<void>(total);
        progress.update(static_cast<unsigned long>(done));
      },
      &stats);
  if (!quiet) progress.finish();
  if (rc != 0) {
    err << "umsvins simulate: " << error << "\n";
    return kExitFailure;
  }
  out << "simulate: " << sim::scenario_name(options.scenario) << " dataset written to " << options.out_dir
      << " (seed " << options.seed << ")\n";
  if (options.style == sim::SimStyle::kPhoto && stats.frames > 0) {
    out << "simulate: photo style, " << options.exposure.exposure_ms << " ms exposure, "
        << static_cast<double>(stats.sub_exposures) / stats.frames << " sub-exposures per frame on average (max "
        << stats.max_sub_exposures << ")\n";
  }
  return kExitOk;
}

}  // namespace ums::cli
