#include "board/host/replay_pipeline.hpp"

#include <chrono>
#include <ctime>
#include <cmath>
#include <limits>

#include "board/host/pipeline_options.hpp"
#include "core/estimator/window.hpp"
#include "profiling/alloc_counter.hpp"

namespace ums::cli {

namespace {

// CPU time of the calling thread (s): the work the pipeline did on its core, whatever else the
// machine ran at the same time (wall time on a shared machine mostly measures the scheduler).
double thread_cpu_s() {
  timespec ts{};
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
  return static_cast<double>(ts.tv_sec) + 1e-9 * static_cast<double>(ts.tv_nsec);
}

VioPipelineOptions vio_options_from(const ReplayPipelineOptions& pipeline) {
  VioPipelineOptions o;
  o.frontend_only = pipeline.frontend_only;
  return o;
}

}  // namespace

ReplayPipeline::ReplayPipeline(const AppConfig& config, const ReplayPipelineOptions& options)
    : options_(options),
      times_(new StageTimes()),
      backend_(options.two_core ? new BackendThread() : nullptr),
      vio_(vio_options_from(options), frontend_options_from(config), estimator_options_from(config, options.deterministic),
           config.rig),
      rig_td_s_(config.rig.td_s) {
  fanout_.set(0, &poses_);
  vio_.set_pose_sink(&fanout_);
  vio_.set_frame_observer(this);
  vio_.set_backend_executor(backend_.get());
  // Reserved here so that recording a frame never allocates; beyond it frames are counted only.
  for (auto* v : {&series_.t_s, &series_.frontend_ms, &series_.total_ms, &series_.backend_ms, &series_.est_t_s,
                  &series_.est_td_ms})
    v->reserve(options.report_frames);
  series_.est_p_w_m.reserve(options.report_frames);
  for (auto* v : {&series_.n_3d, &series_.n_2d_left, &series_.n_2d_right}) v->reserve(options.report_frames);
}

ReplayPipeline::~ReplayPipeline() { stop_backend(); }  // what is queued runs while this object exists

BackendStopper::~BackendStopper() { pipeline->stop_backend(); }

void ReplayPipeline::stop_backend() noexcept {
  try {
    vio_.set_backend_executor(nullptr);
  } catch (...) {
    // A back-end error not collected by end_of_input(): the caller is already unwinding.
  }
}

void ReplayPipeline::end_of_input() {
  const auto start = std::chrono::steady_clock::now();
  const double cpu_start_s = thread_cpu_s();
  vio_.flush();
  summary_.processing_s += std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  summary_.processing_cpu_s += thread_cpu_s() - cpu_start_s;
}

void ReplayPipeline::note_time(std::int64_t t_ns) {
  if (first_t_ns_ < 0) first_t_ns_ = t_ns;
  if (t_ns > last_t_ns_) last_t_ns_ = t_ns;
}

void ReplayPipeline::on_imu(const ImuSample& sample) {
  const bool steady = vio_.counters().frames >= options_.steady_state_from_frame;
  AllocScope allocs;
  const auto start = std::chrono::steady_clock::now();
  const double cpu_start_s = thread_cpu_s();
  vio_.on_imu(sample);
  summary_.processing_s +=
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  summary_.processing_cpu_s += thread_cpu_s() - cpu_start_s;
  if (steady) summary_.heap_allocs_steady_state += allocs.allocations();
}

void ReplayPipeline::on_stereo(const StereoFrame& frame) {
  const bool steady = vio_.counters().frames >= options_.steady_state_from_frame;
  if (steady && !steady_seen_) {
    steady_seen_ = true;
    if (backend_ != nullptr) {
      vio_.wait_backend();  // the warm-up frames' back end is done: its allocations are warm-up's
      backend_allocs_at_steady_ = backend_->allocations();
    }
  }
  AllocScope allocs;
  const auto start = std::chrono::steady_clock::now();
  const double cpu_start_s = thread_cpu_s();
  note_time(frame.t_ns);
  vio_.on_stereo(frame);
  summary_.processing_s += std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  summary_.processing_cpu_s += thread_cpu_s() - cpu_start_s;
  if (steady) summary_.heap_allocs_steady_state += allocs.allocations();
}

void ReplayPipeline::on_frame_done(const VioFrameRecord& record, const StereoFrame& frame) {
  times_->record(Stage::kTotal, record.total_ms);
  record_stage_times(record);
  record_series(record, frame);
}

void ReplayPipeline::record_stage_times(const VioFrameRecord& frame) {
  times_->record(Stage::kFrontend, static_cast<double>(frame.frontend_ms));
  if (frame.frontend_status == Status::kOk) {
    accumulate_features(vio_.features());
    const FrontendFrameStats& fs = vio_.features().stats;
    times_->record(Stage::kPyramid, static_cast<double>(fs.pyramid_ms));
    times_->record(Stage::kDetect, static_cast<double>(fs.detect_ms));
    times_->record(Stage::kTrack, static_cast<double>(fs.track_ms));
    times_->record(Stage::kStereo, static_cast<double>(fs.stereo_ms));
    times_->record(Stage::kRansac, static_cast<double>(fs.ransac_ms));
  }
  if (!frame.estimated) return;
  const EstimatorTiming& timing = frame.timing;
  times_->record(Stage::kPreintegrate, static_cast<double>(timing.preintegrate_ms));
  if (frame.estimate.mode != EstimatorMode::kImuOnly) {
    times_->record(Stage::kSolveRound1, static_cast<double>(timing.solve_round1_ms));
    times_->record(Stage::kSolveRound2, static_cast<double>(timing.solve_round2_ms));
  }
  if (timing.marginalize_ms > 0.0f) times_->record(Stage::kMarginalize, static_cast<double>(timing.marginalize_ms));
  times_->record(Stage::kBackend, static_cast<double>(timing.backend_ms));
}

void ReplayPipeline::record_series(const VioFrameRecord& rec, const StereoFrame& frame) {
  const double total_ms = rec.total_ms;
  const double t_s = static_cast<double>(frame.t_ns - first_t_ns_) * 1e-9;
  if (rec.estimated && rec.estimate.valid && series_.est_t_s.size() < series_.est_t_s.capacity()) {
    series_.est_t_s.push_back(t_s);
    series_.est_p_w_m.push_back(rec.estimate.p_w_b);
    series_.est_td_ms.push_back(rec.estimate.td_s * 1e3);
  }
  if (series_.t_s.size() >= series_.t_s.capacity()) {
    ++series_dropped_;
    return;
  }
  const bool ok = rec.frontend_status == Status::kOk;
  const FrameFeatures& f = vio_.features();
  series_.t_s.push_back(t_s);
  series_.frontend_ms.push_back(rec.frontend_ms);
  series_.backend_ms.push_back(rec.estimated ? static_cast<double>(rec.timing.backend_ms) : 0.0);
  series_.total_ms.push_back(total_ms);
  series_.n_3d.push_back(ok ? f.n_3d : 0);
  series_.n_2d_left.push_back(ok ? f.n_2d_left : 0);
  series_.n_2d_right.push_back(ok ? f.n_2d_right : 0);
}

void ReplayPipeline::accumulate_features(const FrameFeatures& f) {
  ++frontend_frames_;
  if (f.features.size() > peak_features_) peak_features_ = f.features.size();
  sum_3d_ += f.n_3d;
  sum_2d_left_ += f.n_2d_left;
  sum_2d_right_ += f.n_2d_right;
  for (const FeatureObservation& o : f.features) sum_track_length_ += o.track_length;
  observations_ += static_cast<double>(f.features.size());
  const double rms = static_cast<double>(f.stats.stereo_epipolar_rms_px);
  sum_sq_epipolar_px_ += rms * rms * f.n_3d;
  epipolar_matches_ += f.n_3d;
}

ReplaySummary ReplayPipeline::summary() const {
  ReplaySummary s = summary_;
  if (backend_ != nullptr) {
    s.processing_cpu_s += backend_->cpu_s();
    if (steady_seen_) s.heap_allocs_steady_state += backend_->allocations() - backend_allocs_at_steady_;
  }
  const VioPipelineCounters& c = vio_.counters();
  s.frames = c.frames;
  s.imu_samples = c.imu_samples;
  s.keyframes = c.keyframes;
  s.frontend_rejected_frames = c.frontend_rejected_frames;
  s.saturated_samples = c.saturated_samples;
  s.duration_s = first_t_ns_ < 0 ? 0.0 : static_cast<double>(last_t_ns_ - first_t_ns_) * 1e-9;
  if (frontend_frames_ > 0) {
    const double n = static_cast<double>(frontend_frames_);
    s.mean_3d = sum_3d_ / n;
    s.mean_2d_left = sum_2d_left_ / n;
    s.mean_2d_right = sum_2d_right_ / n;
  }
  if (observations_ > 0) s.mean_track_length = sum_track_length_ / observations_;
  if (epipolar_matches_ > 0) s.stereo_epipolar_rms_px = std::sqrt(sum_sq_epipolar_px_ / epipolar_matches_);
  return s;
}

void ReplayPipeline::write_stats(JsonWriter& w) const {
  const ReplaySummary s = summary();
  w.value("frames", s.frames);
  w.value("imu_samples", s.imu_samples);
  w.value("duration_s", s.duration_s);
  w.value("processing_s", s.processing_s, 4);
  w.value("processing_cpu_s", s.processing_cpu_s, 4);
  write_threads(w);
  write_timing_stats(w);
  w.begin_object("features")
      .value("mean_3d", s.mean_3d, 5)
      .value("mean_2d_left", s.mean_2d_left, 5)
      .value("mean_2d_right", s.mean_2d_right, 5)
      .value("mean_track_length", s.mean_track_length, 5)
      .value("stereo_epipolar_rms_px", s.stereo_epipolar_rms_px, 4)
      .value("keyframes", s.keyframes)
      .end_object();
  w.begin_object("imu")
      .value("saturated_samples", s.saturated_samples)
      .value("implausible_samples", vio_.counters().imu_implausible)
      .end_object();
  if (has_estimator()) write_estimator_stats(w);
  write_memory_stats(w);
  write_drops(w, s);
}

void ReplayPipeline::write_timing_stats(JsonWriter& w) const {
  w.begin_object("timing_ms");
  for (std::size_t i = 0; i < static_cast<std::size_t>(Stage::kCount); ++i) {
    const Stage stage = static_cast<Stage>(i);
    const StageSummary t = times_->summary(stage);
    if (t.count == 0) continue;
    w.begin_object(stage_name(stage))
        .value("median", t.median_ms, 4)
        .value("p99", t.p99_ms, 4)
        .value("max", t.max_ms, 4)
        .value("mean", t.mean_ms, 4)
        .value("count", t.count)
        .end_object();
  }
  w.end_object();
}

void ReplayPipeline::write_threads(JsonWriter& w) const {
  w.begin_object("threads").value("pipeline", backend_ != nullptr ? 2 : 1);
  if (backend_ != nullptr) {
    w.value("backend_cpu_s", backend_->cpu_s(), 4)
        .value("backend_tasks", backend_->tasks())
        .value("backend_full_waits", backend_->full_waits());
  }
  w.end_object();
}

void ReplayPipeline::write_memory_stats(JsonWriter& w) const {
  w.begin_object("memory")
      .value("heap_allocs_steady_state", summary().heap_allocs_steady_state)
      .value("static_bytes", static_cast<std::uint64_t>(static_bytes_))
      .value("alloc_counter", alloc_counter_available())
      .begin_object("pools")
      .begin_object("frame_features")
      .value("capacity", static_cast<std::uint64_t>(decltype(FrameFeatures::features)::capacity()))
      .value("peak", static_cast<std::uint64_t>(peak_features_))
      .end_object();
  if (const Estimator* est = vio_.estimator()) {
    const EstimatorStats& e = est->stats();
    w.begin_object("landmarks")
        .value("capacity", static_cast<std::uint64_t>(capacity::kMaxLandmarks))
        .value("peak", static_cast<std::uint64_t>(e.peak_landmarks))
        .end_object();
    w.begin_object("visual_residuals")
        .value("capacity", static_cast<std::uint64_t>(capacity::kMaxVisualResiduals))
        .value("peak", static_cast<std::uint64_t>(e.peak_residuals))
        .end_object();
  }
  w.end_object().end_object();
}

void ReplayPipeline::write_drops(JsonWriter& w, const ReplaySummary& s) const {
  w.begin_object("drops")
      .value("imu_out_of_order", vio_.counters().imu_out_of_order)
      .value("frames_not_time_aligned", vio_.time_alignment().frames_unaligned)
      .value("imu_released_early", vio_.time_alignment().imu_released_early)
      .value("frontend_rejected_frames", s.frontend_rejected_frames)
      .value("report_series", series_dropped_);
  if (const Estimator* est = vio_.estimator()) {
    const EstimatorStats& e = est->stats();
    w.value("landmarks", e.drops_landmarks)
        .value("visual_residuals", e.drops_residuals)
        .value("imu_interval", e.drops_imu)
        .value("estimator_frames_out_of_order", e.frames_out_of_order)
        .value("mode_changes", e.mode_changes_dropped);
  }
  w.end_object();
}

// "init", "first_frame_t_ns" and "modes": when the estimator got where.
void ReplayPipeline::write_init_and_modes(JsonWriter& w) const {
  const EstimatorStats& e = vio_.estimator()->stats();
  const double t0_ns = static_cast<double>(e.first_frame_t_ns);
  w.begin_object("init")
      .value("success", e.initialized)
      .value("time_s", e.initialized ? (static_cast<double>(e.init_t_ns) - t0_ns) * 1e-9 : -1.0, 4)
      .value("case", e.initialized ? e.init_case : "none")
      .end_object();
  // The origin of every t_s below, on the dataset clock of trajectory.tum (eval --stats places the
  // poses in the timeline with it; t_s alone keeps 4 significant digits).
  w.value("first_frame_t_ns", static_cast<std::int64_t>(e.first_frame_t_ns));
  w.begin_array("modes");
  for (const ModeChange& c : e.mode_changes) {
    w.begin_object()
        .value("t_s", (static_cast<double>(c.t_ns) - t0_ns) * 1e-9, 4)
        .value("t_ns", static_cast<std::int64_t>(c.t_ns))
        .value("from", to_string(c.from))
        .value("to", to_string(c.to))
        .value("reason", c.reason)
        .end_object();
  }
  w.end_array();
}

void ReplayPipeline::write_estimator_stats(JsonWriter& w) const {
  const Estimator& est = *vio_.estimator();
  const EstimatorStats& e = est.stats();
  write_init_and_modes(w);
  w.begin_object("estimator")
      .value("mode", to_string(est.mode()))
      .value("frames_imu_only", e.frames_in_mode[0])
      .value("frames_vo", e.frames_in_mode[1])
      .value("frames_vio", e.frames_in_mode[2])
      .value("frames_vision_lost", e.frames_in_mode[3])
      .value("poses_written", poses_.poses_written())
      .value("frames_without_pose", e.frames_without_pose)
      .value("solves", e.solves)
      .value("problem_builds", e.problem_builds)
      .value("solver_iterations", e.solver_iterations)
      .value("solver_successful_steps", e.solver_successful_steps)
      .value("solver_linearizations", e.solver_linearizations)
      .value("solver_gradient_passes", e.solver_gradient_passes)
      .value("solver_factor_reuses", e.solver_factor_reuses)
      .value("solver_residual_passes", e.solver_residual_passes)
      .value("mean_landmarks_in_solve", e.frames_solved > 0 ? e.sum_landmarks_in_solve / static_cast<double>(e.frames_solved) : 0.0, 4)
      .value("mean_2d_in_solve", e.frames_solved > 0 ? e.sum_2d_in_solve / static_cast<double>(e.frames_solved) : 0.0, 4)
      .value("stage_kept_2d_left", e.stage_kept_2d_left)
      .value("stage_added_2d_right", e.stage_added_2d_right)
      .value("stage_3d_sufficient", e.stage_3d_sufficient)
      .value("stage_few_2d_left", e.stage_few_2d_left)
      .value("outlier_landmarks", e.outlier_landmarks)
      .value("second_rounds", e.second_rounds)
      .value("second_rounds_skipped", e.second_rounds_skipped)
      .value("second_round_rebuilds", e.second_round_rebuilds)
      .value("outliers_into_prior", e.outliers_into_prior)
      .value("marginalized_old", e.marginalized_old)
      .value("marginalized_second_new", e.marginalized_second_new)
      .value("marginalization_failures", e.marginalization_failures)
      .value("marginalizations_reused", e.marginalizations_reused)
      .value("visual_init_failures", e.visual_init_failures)
      .value("align_attempts", e.align_attempts)
      .value("align_failures", e.align_failures)
      .value("align_unobservable", e.align_unobservable)
      .value("align_tilt_sigma_deg", e.align_tilt_sigma_deg)
      .value("imu_samples_held", e.imu_held)
      .value("imu_gap_frames", e.imu_gap_frames)
      .value("still_frames", e.still_frames)
      .value("still_rejected_by_vision", e.still_rejected_by_vision)
      .value("resets", e.resets)
      .value("relevels", e.relevels)
      .value("relocation_requests", e.relocation_requests)
      .value("relocations_solved", e.relocations_solved)
      .value("relocation_residuals", e.relocation_residuals)
      .end_object();
  write_time_offset_stats(w);
  write_gyro_scale_stats(w);
  write_extrinsic_stats(w);
}

void ReplayPipeline::write_time_offset_stats(JsonWriter& w) const {
  const Estimator& est = *vio_.estimator();
  // td_ms: the calibration's; estimate_ms: the window's at the end (the same unless estimate_td);
  // applied_ms: what the aligner stamps the frames with now (the estimate, with estimate_td).
  w.begin_object("time_offset")
      .value("td_ms", rig_td_s_ * 1e3, 4)
      .value("frames_held_for_imu", vio_.time_alignment().frames_held)
      .value("estimated", est.options().estimate_td)
      .value("estimate_ms", est.window().time_offset().value_s() * 1e3, 4)
      .value("applied_ms", static_cast<double>(vio_.applied_td_ns()) * 1e-6, 4)
      .value("frames_restamped", vio_.time_alignment().frames_restamped)
      .value("clamped_solves", est.stats().td_clamped);
  if (est.options().estimate_td) write_td_series(w);
  w.end_object();
}

void ReplayPipeline::write_gyro_scale_stats(JsonWriter& w) const {
  const Estimator& est = *vio_.estimator();
  const Eigen::Vector3d s = est.window().gyro_scale().value() * 100.0;
  w.begin_object("gyro_scale")
      .value("estimated", est.options().estimate_gyro_scale)
      .begin_array("estimate_pct")
      .value(nullptr, s.x(), 4)
      .value(nullptr, s.y(), 4)
      .value(nullptr, s.z(), 4)
      .end_array()
      .value("clamped_solves", est.stats().gyro_scale_clamped)
      .end_object();
}

// The estimate once per second of the run (the first frame with a pose in each second), as
// [t_s, td_ms] pairs: how fast and how close it settles, without the report.
void ReplayPipeline::write_td_series(JsonWriter& w) const {
  w.begin_array("series_t_s_td_ms");
  double next_s = 0.0;
  for (std::size_t i = 0; i < series_.est_t_s.size() && i < series_.est_td_ms.size(); ++i) {
    if (series_.est_t_s[i] < next_s) continue;
    w.begin_array(nullptr).value(nullptr, series_.est_t_s[i], 6).value(nullptr, series_.est_td_ms[i], 4).end_array();
    next_s = std::floor(series_.est_t_s[i]) + 1.0;
  }
  w.end_array();
}

void ReplayPipeline::write_extrinsic_stats(JsonWriter& w) const {
  const Estimator& est = *vio_.estimator();
  const EstimatorStats& e = est.stats();
  const Extrinsics& x = est.window().extrinsics();
  // How far the estimate moved from the calibration: each camera, and the stereo pair's relative
  // pose (the baseline prior's job to keep).
  auto moved = [](const Eigen::Isometry3d& a, const Eigen::Isometry3d& b, double* deg, double* mm) {
    const Eigen::Isometry3d d = a.inverse() * b;
    *deg = Eigen::AngleAxisd(d.linear()).angle() * 180.0 / M_PI;
    *mm = d.translation().norm() * 1e3;
  };
  double deg[3], mm[3];
  for (int c = 0; c < 2; ++c) moved(x.calibration(c), x.T_b_c(c), &deg[c], &mm[c]);
  moved(x.calibration(0).inverse() * x.calibration(1), x.T_b_c(0).inverse() * x.T_b_c(1), &deg[2], &mm[2]);
  w.begin_object("extrinsic")
      .value("estimated", x.floating())
      .value("released_s", e.extrinsic_released_t_ns >= 0
                               ? (static_cast<double>(e.extrinsic_released_t_ns - e.first_frame_t_ns)) * 1e-9 : -1.0, 4)
      .value("max_rotation_excitation_deg", e.max_rotation_excitation_deg, 4)
      .value("cam0_change_deg", deg[0], 4)
      .value("cam0_change_mm", mm[0], 4)
      .value("cam1_change_deg", deg[1], 4)
      .value("cam1_change_mm", mm[1], 4)
      .value("stereo_change_deg", deg[2], 4)
      .value("stereo_change_mm", mm[2], 4);
  // The estimates themselves: T_b_c per camera as [x y z] m and [qx qy qz qw].
  for (int c = 0; c < 2; ++c) {
    const Eigen::Vector3d p = x.T_b_c(c).translation();
    const Eigen::Quaterniond q(x.T_b_c(c).linear());
    w.begin_array(c == 0 ? "cam0_p_b_c_m" : "cam1_p_b_c_m");
    for (int i = 0; i < 3; ++i) w.value(nullptr, p[i], 9);
    w.end_array();
    w.begin_array(c == 0 ? "cam0_q_b_c" : "cam1_q_b_c");
    for (double v : {q.x(), q.y(), q.z(), q.w()}) w.value(nullptr, v, 9);
    w.end_array();
  }
  w.end_object();
}

void ReplayPipeline::print_summary(std::ostream& out) const {
  const ReplaySummary s = summary();
  out << "replay: features per frame: " << s.mean_3d << " 3D, " << s.mean_2d_left << " 2D-left, "
      << s.mean_2d_right << " 2D-right; mean track length " << s.mean_track_length
      << " frames; stereo epipolar RMS " << s.stereo_epipolar_rms_px << " px; " << s.keyframes
      << " keyframes\n";
  if (s.saturated_samples > 0) {
    out << "replay: saturation element clipped " << s.saturated_samples << " IMU samples\n";
  }
  if (vio_.counters().imu_implausible > 0) {
    out << "replay: dropped " << vio_.counters().imu_implausible
        << " IMU samples that are no reading (not finite, or beyond the sensor range)\n";
  }
  out << "replay: steady-state heap allocations in the pipeline: "
      << s.heap_allocs_steady_state << "\n";
}

}  // namespace ums::cli
