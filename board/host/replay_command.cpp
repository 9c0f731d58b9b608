// umsvins replay: streams an EuRoC-layout dataset through the pipeline and reports.
//
// The pipeline runs the front end and the estimator (--frontend-only: the front end alone, no
// trajectory). trajectory.tum is written frame by frame while the replay runs; when the dataset
// has ground truth the run ends with the ATE (SE(3) alignment) in stats.json and on stdout.

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <thread>

#include "board/config/app_config.hpp"
#include "board/host/cli_args.hpp"
#include "board/host/commands.hpp"
#include "board/host/fault_args.hpp"
#include "board/host/loop_session.hpp"
#include "board/host/mavlink_args.hpp"
#include "board/host/replay_pipeline.hpp"
#include "core/common/version.hpp"
#include "core/estimator/window.hpp"
#include "hal/replay/euroc_reader.hpp"
#include "profiling/alloc_counter.hpp"
#include "profiling/eval/error_budget.hpp"
#include "profiling/eval/eval_command.hpp"
#include "profiling/eval/metrics.hpp"
#include "profiling/eval/report_html.hpp"
#include "profiling/eval/trajectory.hpp"
#include "hal/replay/euroc_groundtruth.hpp"
#include "profiling/json_writer.hpp"
#include "profiling/progress.hpp"

namespace ums::cli {
namespace {

void write_file(const std::filesystem::path& path, const std::string& text) {
  std::ofstream f(path);
  if (!f) throw std::runtime_error(path.string() + ": cannot open for writing");
  f << text;
  if (!f) throw std::runtime_error(path.string() + ": write failed");
}

// Peak resident set of the process so far (VmHWM), in KiB; -1 where /proc is not there.
long peak_rss_kib() {
  std::ifstream status("/proc/self/status");
  std::string line;
  while (std::getline(status, line)) {
    if (line.rfind("VmHWM:", 0) == 0) return std::atol(line.c_str() + 6);
  }
  return -1;
}

// The estimator's own mode timeline (what eval --stats reads back from stats.json).
eval::ModeTimeline mode_timeline_of(const EstimatorStats& e) {
  eval::ModeTimeline t;
  t.origin_known = true;
  t.origin_t_ns = e.first_frame_t_ns;
  if (!e.mode_changes.empty()) t.initial_mode = to_string(e.mode_changes[0].from);
  for (const ModeChange& c : e.mode_changes) t.changes.push_back({c.t_ns - e.first_frame_t_ns, to_string(c.to)});
  return t;
}

std::string fixed(double v, int decimals, const char* unit) {
  if (!std::isfinite(v)) return "n/a";
  char b[64];
  std::snprintf(b, sizeof b, "%.*f %s", decimals, v, unit);
  return b;
}

// The budget as the report draws it (times already on the first-frame clock of the mode bars).
eval::ReportBudget report_budget(const eval::ErrorBudget& b) {
  eval::ReportBudget r;
  r.present = true;
  r.t_s = b.t_s;
  r.error_m = b.error_m;
  for (const eval::PhaseError& p : b.phases) {
    r.phases.push_back({p.mode, p.poses, p.duration_s, p.ate_rmse_m, 100.0 * p.share_of_ate2});
  }
  r.figures = {{"ATE RMSE, whole flight (SE(3))", fixed(b.ate_rmse_m, 4, "m")},
               {"scale error (Sim(3))", fixed(b.scale_error_pct, 3, "%")},
               {"yaw error at the end (anchor: first " + fixed(b.anchor_s, 1, "s") + ")", fixed(b.yaw_error_end_deg, 3, "deg")},
               {"yaw drift", fixed(b.yaw_drift_deg_per_min, 3, "deg/min")},
               {"final position drift", fixed(b.final_drift_m, 4, "m") + " over " + fixed(b.distance_m, 2, "m") + " = " +
                                            fixed(b.final_drift_pct, 3, "%")}};
  r.has_worst = b.worst.found;
  if (b.worst.found) {
    r.worst_start_s = b.worst.start_s;
    r.worst_end_s = b.worst.end_s;
    r.worst_rmse_m = b.worst.rmse_m;
    r.worst_mode = b.worst.mode;
    r.figures.push_back({"worst " + fixed(b.window_s, 0, "s"), fixed(b.worst.start_s, 2, "s") + " to " +
                                                                 fixed(b.worst.end_s, 2, "s") + ": " +
                                                                 fixed(b.worst.rmse_m, 4, "m") + " in " + b.worst.mode});
  }
  return r;
}

// report.html: what the run has today (features and timing per frame, the ground truth's path
// when the dataset has one; the estimate and its error once the estimator exists).
// Loop closure in the report: the final map trajectory (read back from trajectory_map.tum, aligned
// like the estimate) and the accepted loops, times on the clock of the modes.
void add_loops(const LoopSession& loop, const eval::EvalResult* accuracy, double t0_ns, eval::ReportData* data,
               std::ostream& err) {
  auto aligned = [&](const Eigen::Vector3d& p) { return accuracy != nullptr ? accuracy->ate.alignment.apply(p) : p; };
  try {
    for (const eval::StampedPose& pose : eval::read_tum(loop.map_trajectory_path().string()).poses) {
      data->map_estimate.t_s.push_back((static_cast<double>(pose.t_ns) - t0_ns) * 1e-9);
      data->map_estimate.p_w_m.push_back(aligned(pose.p_w_x));
    }
  } catch (const std::exception& e) {
    err << "warning: the map-frame trajectory not shown in the report: " << e.what() << "\n";
  }
  const loop::LoopCloser& closer = loop.closer();
  for (std::size_t i = 0; i < closer.num_events(); ++i) {
    const loop::LoopEvent& e = closer.event(i);
    data->loops.push_back({(static_cast<double>(e.t_query_ns) - t0_ns) * 1e-9, aligned(e.p_map_query),
                           aligned(e.p_map_loop), e.inliers, e.correction_m, e.correction_deg, e.relocalization});
  }
}

// The ground truth's path in the report, streamed row by row (the ground truth of a long flight is
// large); a plot needs no more than one point per 50 ms.
void add_groundtruth(const hal::EurocReader& reader, double duration_s, eval::ReportData* data, std::ostream& err) {
  try {
    hal::EurocGroundtruthReader gt;
    gt.open(reader.groundtruth_path());
    const double t0_ns = static_cast<double>(reader.window_start_t_ns());
    double last_t_s = -1.0;
    hal::GroundTruthState state;
    while (gt.next(&state) == hal::CsvReader::Result::kRow) {
      const double t_s = (static_cast<double>(state.t_ns) - t0_ns) * 1e-9;
      if (t_s < 0.0 || t_s > duration_s || t_s - last_t_s < 0.05) continue;
      last_t_s = t_s;
      data->groundtruth.t_s.push_back(t_s);
      data->groundtruth.p_w_m.push_back(state.p_w_b);
    }
    if (gt.error()[0] != '\0') err << "warning: ground truth in the report stops at " << gt.error() << "\n";
  } catch (const std::exception& e) {
    err << "warning: ground truth not shown in the report: " << e.what() << "\n";
  }
}

void write_report(const std::string& dataset, const hal::EurocReader& reader, const ReplayPipeline& pipeline,
                  const ReplaySummary& summary, const eval::EvalResult* accuracy,
                  const eval::ErrorBudget* budget, const LoopSession* loop, const std::filesystem::path& path,
                  std::ostream& err) {
  eval::ReportData data;
  data.title = "umsvins replay: " + dataset;
  data.summary = {{"dataset", dataset},
                  {"frames", std::to_string(summary.frames)},
                  {"duration", std::to_string(summary.duration_s) + " s"},
                  {"pipeline time", std::to_string(summary.processing_s) + " s"},
                  {"estimator", pipeline.has_estimator() ? "UMS-VINS" : "off (--frontend-only)"}};
  if (accuracy != nullptr) {
    data.summary.push_back({"ATE RMSE (SE(3))", std::to_string(accuracy->ate.translation_m.rmse) + " m over " +
                                                    std::to_string(accuracy->matched) + " poses"});
    data.error_t_s = accuracy->ate.t_s;
    data.error_m = accuracy->ate.error_m;
  }
  if (const Estimator* est = pipeline.estimator()) {
    const EstimatorStats& e = est->stats();
    data.summary.push_back({"initialized", e.initialized ? std::string("yes (") + e.init_case + ")" : "no"});
    const double t0 = static_cast<double>(e.first_frame_t_ns);
    data.modes.push_back({0.0, "IMU_ONLY"});
    for (const ModeChange& c : e.mode_changes) data.modes.push_back({(static_cast<double>(c.t_ns) - t0) * 1e-9, to_string(c.to)});
    const ReplayPipeline::FrameSeries& fs = pipeline.series();
    data.estimate.t_s = fs.est_t_s;
    if (est->options().estimate_td) {
      data.time_offset.present = true;
      data.time_offset.t_s = fs.est_t_s;
      data.time_offset.td_ms = fs.est_td_ms;
      data.time_offset.calibration_ms = est->window().time_offset().calibration_s() * 1e3;
    }
    for (const Eigen::Vector3d& p : fs.est_p_w_m)
      data.estimate.p_w_m.push_back(accuracy != nullptr ? accuracy->ate.alignment.apply(p) : p);
    if (loop != nullptr) add_loops(*loop, accuracy, t0, &data, err);
  }
  const ReplayPipeline::FrameSeries& s = pipeline.series();
  data.features.t_s = s.t_s;
  data.features.n_3d = s.n_3d;
  data.features.n_2d_left = s.n_2d_left;
  data.features.n_2d_right = s.n_2d_right;
  data.stage_timings.push_back({"frontend", s.frontend_ms});
  if (pipeline.has_estimator()) data.stage_timings.push_back({"backend", s.backend_ms});
  data.stage_timings.push_back({"total", s.total_ms});
  data.end_t_s = summary.duration_s;
  if (budget != nullptr) data.budget = report_budget(*budget);
  if (reader.has_groundtruth()) add_groundtruth(reader, summary.duration_s, &data, err);
  std::string error;
  if (!eval::write_report_html(data, path.string(), &error)) throw std::runtime_error(error);
}

// The estimate's files, open while the pipeline writes them.
struct EstimateFiles {
  std::filesystem::path trajectory_path, states_path;
  std::FILE* trajectory = nullptr;
  std::FILE* states = nullptr;
};

EstimateFiles open_estimate_files(const std::filesystem::path& out_dir, ReplayPipeline& pipeline) {
  EstimateFiles f{out_dir / "trajectory.tum", out_dir / "states.csv"};
  if (!pipeline.has_estimator()) return f;
  f.trajectory = std::fopen(f.trajectory_path.c_str(), "w");
  if (f.trajectory == nullptr) throw std::runtime_error(f.trajectory_path.string() + ": cannot open for writing");
  std::fputs("# t_s x y z qx qy qz qw (body = IMU in world; umsvins replay)\n", f.trajectory);
  pipeline.set_trajectory_output(f.trajectory);
  f.states = std::fopen(f.states_path.c_str(), "w");
  if (f.states == nullptr) throw std::runtime_error(f.states_path.string() + ": cannot open for writing");
  std::fputs(TumPoseSink::state_header(), f.states);
  pipeline.set_state_output(f.states);
  return f;
}

void close_estimate_files(EstimateFiles* f, ReplayPipeline& pipeline) {
  if (f->trajectory == nullptr) return;
  pipeline.set_trajectory_output(nullptr);
  pipeline.set_state_output(nullptr);
  const bool trajectory_ok = std::fclose(f->trajectory) == 0;
  const bool states_ok = std::fclose(f->states) == 0;
  f->trajectory = f->states = nullptr;
  if (!trajectory_ok) throw std::runtime_error(f->trajectory_path.string() + ": write failed");
  if (!states_ok) throw std::runtime_error(f->states_path.string() + ": write failed");
}

struct StreamResult {
  double wall_s = 0.0;
  long peak_rss_kb = 0;  // before the report and stats are built
};

// Every IMU sample and stereo pair of the dataset through the pipeline, paced by the data's own
// clock with --realtime (as a live sensor would deliver it).
// faults: between the reader and the pipeline (replay --fault), or nullptr.
StreamResult stream(hal::EurocReader& reader, ReplayPipeline& pipeline, hal::FaultInjector* faults, bool realtime,
                    bool quiet, std::ostream& err) {
  MeasurementSink& in = faults != nullptr ? static_cast<MeasurementSink&>(*faults) : pipeline;
  Progress progress("replay", static_cast<unsigned long>(reader.total_pairs_estimate()));
  const auto wall_start = std::chrono::steady_clock::now();
  std::int64_t first_t_ns = -1;
  ImuSample imu;
  StereoFrame frame;
  for (;;) {
    const hal::EurocReader::Event event = reader.next(&imu, &frame);
    if (event == hal::EurocReader::Event::kEnd) break;
    const std::int64_t t_ns = event == hal::EurocReader::Event::kImu ? imu.t_ns : frame.t_ns;
    if (first_t_ns < 0) first_t_ns = t_ns;
    if (realtime) std::this_thread::sleep_until(wall_start + std::chrono::nanoseconds(t_ns - first_t_ns));
    if (event == hal::EurocReader::Event::kImu) {
      in.on_imu(imu);
    } else {
      in.on_stereo(frame);
      if (!quiet) progress.update(static_cast<unsigned long>(pipeline.frames()));
    }
  }
  if (faults != nullptr) faults->flush();
  pipeline.end_of_input();
  if (reader.status() != Status::kOk) {
    // The files changed under us after open() validated them: say where, keep what was done.
    err << "umsvins replay: stopped early: " << reader.error() << "\n";
  }
  StreamResult r;
  r.wall_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - wall_start).count();
  r.peak_rss_kb = peak_rss_kib();
  if (!quiet) progress.finish();
  return r;
}

struct Accuracy {
  std::unique_ptr<eval::EvalResult> result;
  std::unique_ptr<eval::ErrorBudget> budget;
};

// Accuracy against the dataset's ground truth, when it has one (warnings, never fatal).
Accuracy evaluate_accuracy(const ReplayPipeline& pipeline, const hal::EurocReader& reader, const AppConfig& config,
                           const std::filesystem::path& trajectory_path, std::ostream& err) {
  Accuracy a;
  if (!pipeline.has_estimator() || !reader.has_groundtruth() || pipeline.poses_written() < 3) return a;
  try {
    const eval::Trajectory est = eval::read_trajectory(trajectory_path.string(), eval::TrajectoryFormat::kTum);
    const eval::Trajectory gt = eval::read_trajectory(reader.groundtruth_path());
    const eval::Trajectory est_in_gt = eval::to_frame(est, gt.frame, config.rig.cam[0].T_b_c);
    eval::MetricsOptions mo;
    mo.rpe_times_s = {1.0, 5.0, 10.0};  // stats.json's rpe_1s_m and rpe_10s_m among them
    a.result = std::make_unique<eval::EvalResult>(eval::evaluate(est_in_gt, gt, mo));
    try {
      const eval::ModeTimeline timeline = mode_timeline_of(pipeline.estimator()->stats());
      a.budget = std::make_unique<eval::ErrorBudget>(
          eval::compute_error_budget(est_in_gt, gt, &timeline, eval::BudgetOptions{}));
    } catch (const std::exception& e) {
      err << "warning: no error budget: " << e.what() << "\n";
    }
  } catch (const std::exception& e) {
    err << "warning: no accuracy figures: " << e.what() << "\n";
  }
  return a;
}

void write_accuracy_json(const Accuracy& a, JsonWriter& w) {
  if (a.result == nullptr) return;
  w.begin_object("accuracy")
      .value("align", "se3")
      .value("matched_poses", static_cast<std::uint64_t>(a.result->matched))
      .value("ate_rmse_m", a.result->ate.translation_m.rmse, 6)
      .value("ate_max_m", a.result->ate.translation_m.max, 6)
      .value("rotation_rmse_deg", a.result->ate.rotation_deg.rmse, 6);
  // The mean error over 1 s segments (local accuracy) and over 10 s ones (drift). Per frame
  // changes move both far less chaotically than the ATE, which one drift event can set; a change
  // of the drift rate shows over 10 s and not over 1 s (docs/performance.md, sessions 30, 31).
  struct Segment {
    double delta_s;
    const char* key_m;
    const char* key_deg;
  };
  for (const Segment& s : {Segment{1.0, "rpe_1s_m", "rpe_1s_deg"}, Segment{10.0, "rpe_10s_m", "rpe_10s_deg"}}) {
    for (const eval::RpeResult& r : a.result->rpe) {
      if (r.unit != eval::RpeUnit::kSeconds || r.delta != s.delta_s || r.translation_m.count == 0) continue;
      w.value(s.key_m, r.translation_m.mean, 7).value(s.key_deg, r.rotation_deg.mean, 6);
      break;
    }
  }
  if (a.budget != nullptr) {
    w.begin_object("budget");
    eval::write_error_budget_json(*a.budget, w);
    w.end_object();
  }
  w.end_object();
}

void write_input_json(const hal::EurocReaderCounters& counters, JsonWriter& w) {
  w.begin_object("input")
      .value("stereo_pairs", static_cast<std::uint64_t>(counters.stereo_pairs))
      .value("unpaired_left", static_cast<std::uint64_t>(counters.unpaired_left))
      .value("unpaired_right", static_cast<std::uint64_t>(counters.unpaired_right))
      .value("unreadable_images", static_cast<std::uint64_t>(counters.unreadable_images))
      .end_object();
}

// Per-pose error over time (after the SE(3) alignment), for plots and regressions.
void write_ate_errors(const eval::EvalResult& accuracy, const std::filesystem::path& path) {
  std::ostringstream csv;
  csv << "# t_s (since the first ground-truth pose), ate_error_m\n";
  for (std::size_t i = 0; i < accuracy.ate.t_s.size(); ++i) csv << accuracy.ate.t_s[i] << "," << accuracy.ate.error_m[i] << "\n";
  write_file(path, csv.str());
}

void print_run(const ReplaySummary& summary, const hal::EurocReaderCounters& counters, double wall_s,
               const ReplayPipeline& pipeline, const eval::EvalResult* accuracy, const std::filesystem::path& out_dir,
               const std::filesystem::path& trajectory_path, std::ostream& out) {
  out << "replay: " << summary.frames << " stereo pairs, " << summary.imu_samples
      << " IMU samples, " << summary.duration_s << " s of data in " << wall_s << " s ("
      << summary.processing_s << " s in the pipeline, " << summary.processing_cpu_s << " s of CPU; "
      << (summary.duration_s > 0.0 ? summary.processing_cpu_s / summary.duration_s : 0.0) << " of real time)\n";
  if (counters.unpaired_left + counters.unpaired_right + counters.unreadable_images > 0) {
    out << "replay: skipped " << counters.unpaired_left << " unpaired left, "
        << counters.unpaired_right << " unpaired right, " << counters.unreadable_images
        << " unreadable images\n";
  }
  pipeline.print_summary(out);
  if (const Estimator* est = pipeline.estimator()) {
    const EstimatorStats& e = est->stats();
    out << "replay: " << pipeline.poses_written() << " poses; ";
    if (e.initialized) {
      out << "VIO from " << (static_cast<double>(e.init_t_ns - e.first_frame_t_ns) * 1e-9) << " s (" << e.init_case << ")";
    } else {
      out << "never reached VIO";
    }
    out << "; frames IMU_ONLY/VO/VIO/VISION_LOST " << e.frames_in_mode[0] << "/" << e.frames_in_mode[1] << "/"
        << e.frames_in_mode[2] << "/" << e.frames_in_mode[3] << "\n";
    if (accuracy != nullptr) {
      out << "replay: ATE RMSE " << accuracy->ate.translation_m.rmse << " m (SE(3) alignment, " << accuracy->matched
          << " poses), max " << accuracy->ate.translation_m.max << " m\n";
    }
    out << "replay: wrote " << trajectory_path.string() << ", ";
  } else {
    out << "replay: --frontend-only: no trajectory; wrote ";
  }
  out << (out_dir / "stats.json").string() << " and " << (out_dir / "report.html").string() << "\n";
}

hal::EurocReaderOptions reader_options_of(const Args& args) {
  hal::EurocReaderOptions o;
  o.start_s = args.get_double("start", 0.0);
  o.duration_s = args.get_double("duration", 0.0);
  if (o.start_s < 0.0) throw UsageError("umsvins replay: --start must be >= 0 s");
  if (o.duration_s < 0.0) throw UsageError("umsvins replay: --duration must be >= 0 s");
  return o;
}

ReplayPipelineOptions pipeline_options_of(const Args& args, const hal::EurocReader& reader) {
  ReplayPipelineOptions o;
  o.frontend_only = args.has("frontend-only");
  o.deterministic = args.has("deterministic");
  o.two_core = args.has("two-core");
  o.report_frames = reader.total_pairs_estimate() + 16;
  return o;
}

}  // namespace

int run_replay(const std::vector<std::string>& argv, std::ostream& out, std::ostream& err) {
  const Args args("replay", argv, with_mavlink_flags({"realtime", "frontend-only", "quiet", "deterministic", "loop", "no-tight-relocation", "two-core"}),
                  with_mavlink_valued({"config", "out", "start", "duration", "vocabulary", "load-map", "save-map", "map-spread-s",
                                       "fault", "fault-seed"}));
  args.require_positionals(1, "<dataset> (the folder holding mav0/)");
  const std::string dataset = args.positionals()[0];
  const std::filesystem::path out_dir = args.get_or("out", "out/replay");
  hal::EurocReader reader;
  reader.open(dataset, reader_options_of(args));  // throws with file:line on bad input
  const AppConfig config = config_of(args, reader.calibration(), err);
  std::filesystem::create_directories(out_dir);

  const ReplayPipelineOptions pipeline_options = pipeline_options_of(args, reader);
  // Start-up footprint: everything the pipeline allocates while it is built, plus itself.
  AllocScope startup_allocs;
  ReplayPipeline pipeline(config, pipeline_options);
  pipeline.set_static_bytes(static_cast<std::size_t>(startup_allocs.bytes()) + sizeof(ReplayPipeline));
  EstimateFiles files = open_estimate_files(out_dir, pipeline);
  std::unique_ptr<MavlinkSession> mavlink = mavlink_from_args(args, config, out_dir);
  // Loop work on its own thread, except in --deterministic runs; --realtime drops what it cannot
  // take like a live run, a replay as fast as it can waits for it.
  const LoopThreading loop_threading{pipeline_options.deterministic,
                                     args.has("realtime") ? QueueFull::kDrop : QueueFull::kWait};
  std::unique_ptr<LoopSession> loop =
      pipeline.has_estimator() ? loop_from_args(args, config, out_dir, loop_threading) : nullptr;
  if (loop != nullptr) loop->attach(pipeline);
  attach_mavlink(mavlink.get(), loop.get(), pipeline);
  const BackendStopper stop_backend_first{&pipeline};  // --two-core: before loop and mavlink go

  std::unique_ptr<hal::FaultInjector> faults = faults_from_args(args, &pipeline);
  const StreamResult run = stream(reader, pipeline, faults.get(), args.has("realtime"), args.has("quiet"), err);
  const hal::EurocReaderCounters& counters = reader.counters();
  const ReplaySummary summary = pipeline.summary();
  close_estimate_files(&files, pipeline);
  const Accuracy accuracy = evaluate_accuracy(pipeline, reader, config, files.trajectory_path, err);

  JsonWriter w;
  w.begin_object();
  w.value("version", version_string());
  w.value("dataset", dataset);
  w.value("wall_s", run.wall_s, 4);
  w.value("peak_rss_kb", static_cast<std::int64_t>(run.peak_rss_kb));
  pipeline.write_stats(w);
  if (faults != nullptr) write_fault_stats(*args.get("fault"), faults->counters(), w);
  finish_mavlink(mavlink.get(), pipeline, w, out_dir, err);
  // An output that could not be written: exit 1 after the rest.
  const bool failed_write = !finish_loop(loop.get(), pipeline, w, err);
  write_accuracy_json(accuracy, w);
  write_input_json(counters, w);
  w.end_object();
  write_file(out_dir / "stats.json", w.str());
  if (accuracy.result != nullptr) write_ate_errors(*accuracy.result, out_dir / "ate_errors.csv");
  write_report(dataset, reader, pipeline, summary, accuracy.result.get(), accuracy.budget.get(), loop.get(),
               out_dir / "report.html", err);
  print_run(summary, counters, run.wall_s, pipeline, accuracy.result.get(), out_dir, files.trajectory_path, out);
  return failed_write ? kExitFailure : kExitOk;
}

}  // namespace ums::cli
