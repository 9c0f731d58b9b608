// umsvins budget: the memory the pipeline takes, component by component.
//
// Each component is built as the replay/live pipeline builds it, inside an allocation scope: its
// footprint is the object itself plus every byte its constructor allocates. Nothing is estimated
// by hand, so the table stays true when a component changes. After start-up nothing grows
// (stats.json memory.heap_allocs_steady_state shows it for a run).

#include <cstdio>
#include <memory>

#include "board/config/app_config.hpp"
#include "board/host/cli_args.hpp"
#include "board/host/commands.hpp"
#include "board/host/pipeline_options.hpp"
#include "board/host/replay_pipeline.hpp"
#include "core/common/capacity.hpp"
#include "core/estimator/estimator.hpp"
#include "core/frontend/frontend.hpp"
#include "core/imu/preintegration.hpp"
#include "hal/d455/nominal_calibration.hpp"
#include "hal/replay/euroc_reader.hpp"
#include "hal/replay/png_io.hpp"
#include "profiling/alloc_counter.hpp"
#include "profiling/stage_timer.hpp"
#include "solver/problem.hpp"

namespace ums::cli {
namespace {

struct Row {
  const char* name;
  std::size_t bytes;
  std::string note;
};

// make() builds the component on the heap (make_unique), so the scope sees the object itself and
// everything its constructor allocates.
template <typename Make>
std::size_t measure(Make make) {
  AllocScope scope;
  auto object = make();
  const std::size_t bytes = static_cast<std::size_t>(scope.bytes());
  (void)object;
  return bytes;
}

std::string kib(std::size_t bytes) {
  char buf[32];
  std::snprintf(buf, sizeof(buf), "%.1f KiB", static_cast<double>(bytes) / 1024.0);
  return buf;
}

// The parts of the product's memory, each built once as the product builds it and measured.
std::vector<Row> budget_rows(const AppConfig& config) {
  const FrontendOptions frontend_options = frontend_options_from(config);

  std::vector<Row> rows;
  rows.push_back({"frontend", measure([&] { return std::make_unique<Frontend>(frontend_options, config.rig); }),
                  "pyramids of both cameras, detector buffers, tracks"});
  rows.push_back({"frame_features", sizeof(FrameFeatures),
                  std::to_string(capacity::kMaxFeaturesPerCamera) + " features"});
  const EstimatorOptions estimator_options = estimator_options_from(config, false);
  rows.push_back({"estimator", measure([&] { return std::make_unique<Estimator>(estimator_options, config.rig); }),
                  std::to_string(capacity::kWindowSize + 1) + " frame slots (IMU intervals of " +
                      std::to_string(capacity::kMaxImuSamplesBetweenFrames) + " samples), " +
                      std::to_string(capacity::kMaxLandmarks) + " landmarks, " +
                      std::to_string(capacity::kMaxVisualResiduals) + " residuals, solver problem (" +
                      kib(sizeof(solver::Problem)) + ") and 2 priors"});
  rows.push_back({"stage_timers", sizeof(StageTimes),
                  std::to_string(StageTimes::kWindow) + " samples x " +
                      std::to_string(static_cast<int>(Stage::kCount)) + " stages"});
  rows.push_back({"png_decoder", measure([] { return std::make_unique<hal::PngGrayReader>(); }),
                  "replay only: libpng/zlib arena"});
  rows.push_back({"replay_images", static_cast<std::size_t>(2 * config.rig.cam[0].width * config.rig.cam[0].height),
                  "replay only: left + right frame buffers"});

  return rows;
}

}  // namespace

int run_budget(const std::vector<std::string>& argv, std::ostream& out, std::ostream& err) {
  const Args args("budget", argv, {}, {"config", "dataset"});
  args.require_positionals(0, "");

  // Calibration: a dataset's sensor.yaml, else the D455 at its default 848x480 mode; a config
  // file overrides on top of either.
  RigCalibration rig = d455::d455_nominal_calibration(848, 480, 30.0, 200.0);
  std::string source = "D455 nominal 848x480";
  if (args.get("dataset")) {
    hal::EurocReader reader;
    reader.open(*args.get("dataset"));
    rig = reader.calibration();
    source = *args.get("dataset");
  }
  const AppConfig config = config_of(args, rig, err);
  if (args.get("config")) source += " + " + *args.get("config");

  const std::vector<Row> rows = budget_rows(config);
  std::size_t total = 0;
  out << "memory budget (" << source << ", max_cnt " << config.max_cnt << ")\n";
  char line[200];
  for (const Row& r : rows) {
    std::snprintf(line, sizeof(line), "  %-22s %12zu B  %12s  %s\n", r.name, r.bytes, kib(r.bytes).c_str(),
                  r.note.c_str());
    out << line;
    total += r.bytes;
  }
  const std::size_t pipeline =
      measure([&] { return std::make_unique<ReplayPipeline>(config, ReplayPipelineOptions{}); });
  std::snprintf(line, sizeof(line), "  %-22s %12zu B  %12s\n", "total of the rows", total, kib(total).c_str());
  out << line;
  std::snprintf(line, sizeof(line), "  %-22s %12zu B  %12s  %s\n", "replay pipeline", pipeline,
                kib(pipeline).c_str(), "as built by umsvins replay (stats.json memory.static_bytes)");
  out << line;
  return kExitOk;
}

}  // namespace ums::cli
