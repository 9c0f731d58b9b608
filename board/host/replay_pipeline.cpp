#include "board/host/replay_pipeline.hpp"

#include <chrono>
#include <ctime>
#include <cmath>
#include <limits>

#include "core/math/so3.hpp"
#include "profiling/alloc_counter.hpp"

namespace ums::cli {

namespace {

FrontendOptions frontend_options_from(const AppConfig& config) {
  FrontendOptions o;
  o.max_cnt = config.max_cnt;
  o.detect_min_missing = config.detect_min_missing;
  o.detector.min_distance_px = static_cast<float>(config.min_dist_px);
  o.ransac.threshold_px = static_cast<float>(config.f_threshold_px);
  return o;
}

EstimatorOptions estimator_options_from(const AppConfig& config, const ReplayPipelineOptions& pipeline) {
  EstimatorOptions o;
  o.keyframe.min_parallax_px = static_cast<float>(config.keyframe_parallax_px);
  o.focal_px = config.rig.cam[0].fx > 0.0 ? config.rig.cam[0].fx : o.focal_px;
  o.keyframe.focal_px = static_cast<float>(o.focal_px);
  o.estimate_extrinsic = config.estimate_extrinsic;
  o.max_iterations_round2 = config.max_num_iterations;
  o.round2_time_s = pipeline.deterministic ? std::numeric_limits<double>::infinity() : config.max_solver_time_s;
  o.preintegration.noise = ImuNoise::from_calibration(config.rig.imu);
  return o;
}

// CPU time of the calling thread (s): the work the pipeline did on its core, whatever else the
// machine ran at the same time (wall time on a shared machine mostly measures the scheduler).
double thread_cpu_s() {
  timespec ts{};
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
  return static_cast<double>(ts.tv_sec) + 1e-9 * static_cast<double>(ts.tv_nsec);
}

// One TUM line (t_s x y z qx qy qz qw); stdio into a buffered FILE allocates nothing per line.
void write_pose(std::FILE* f, std::int64_t t_ns, const Eigen::Vector3d& p, const Eigen::Quaterniond& q) {
  std::fprintf(f, "%lld.%09lld %.7f %.7f %.7f %.9f %.9f %.9f %.9f\n", static_cast<long long>(t_ns / 1000000000),
               static_cast<long long>(t_ns % 1000000000), p.x(), p.y(), p.z(), q.x(), q.y(), q.z(), q.w());
}

}  // namespace

ReplayPipeline::ReplayPipeline(const AppConfig& config, const ReplayPipelineOptions& options)
    : config_(config),
      options_(options),
      times_(new StageTimes()),
      frontend_(frontend_options_from(config), config.rig),
      estimator_(options.frontend_only ? nullptr : new Estimator(estimator_options_from(config, options), config.rig)),
      features_(new FrameFeatures()),
      q_b_c0_(config.rig.cam[0].T_b_c.rotation()) {
  // Reserved here so that recording a frame never allocates; beyond it frames are counted only.
  for (auto* v : {&series_.t_s, &series_.frontend_ms, &series_.total_ms, &series_.backend_ms, &series_.est_t_s})
    v->reserve(options.report_frames);
  series_.est_p_w_m.reserve(options.report_frames);
  for (auto* v : {&series_.n_3d, &series_.n_2d_left, &series_.n_2d_right}) v->reserve(options.report_frames);
}

ReplayPipeline::~ReplayPipeline() {
  delete features_;
  delete times_;
}

void ReplayPipeline::note_time(std::int64_t t_ns) {
  if (first_t_ns_ < 0) first_t_ns_ = t_ns;
  if (t_ns > last_t_ns_) last_t_ns_ = t_ns;
}

void ReplayPipeline::on_imu(const ImuSample& sample) {
  const bool steady = summary_.frames >= options_.steady_state_from_frame;
  AllocScope allocs;
  const auto start = std::chrono::steady_clock::now();
  const double cpu_start_s = thread_cpu_s();

  if (sample.t_ns <= last_imu_t_ns_) {
    ++out_of_order_imu_;  // a source bug: count, never pass on
  } else {
    ImuSample clipped;
    const bool saturated = saturation_.apply(sample, &clipped);
    if (saturated) ++summary_.saturated_samples;
    if (last_imu_t_ns_ >= 0 && summary_.frames > 0) {
      // Rotation hint only: raw gyro (bias of a few mrad/s moves KLT starts by < 0.1 px at 20 Hz).
      const double dt_s = static_cast<double>(sample.t_ns - last_imu_t_ns_) * 1e-9;
      q_bprev_bcurr_ = (q_bprev_bcurr_ * so3::exp_quat(clipped.gyro_rad_s * dt_s)).normalized();
      have_imu_since_frame_ = true;
    }
    last_imu_t_ns_ = sample.t_ns;
    ++summary_.imu_samples;
    if (estimator_ != nullptr) {
      estimator_->add_imu(clipped, saturated);
      NavState nav;
      if (imu_poses_ != nullptr && summary_.frames > 0 && estimator_->imu_rate_state(&nav)) {
        write_pose(imu_poses_, sample.t_ns, nav.p_w_b, nav.q_w_b);
      }
    }
  }
  summary_.processing_s +=
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  summary_.processing_cpu_s += thread_cpu_s() - cpu_start_s;
  if (steady) summary_.heap_allocs_steady_state += allocs.allocations();
}

void ReplayPipeline::on_stereo(const StereoFrame& frame) {
  const bool steady = summary_.frames >= options_.steady_state_from_frame;
  AllocScope allocs;
  const auto frame_start = std::chrono::steady_clock::now();
  double frontend_ms = 0.0;
  double backend_ms = 0.0;
  {
    ScopedStageTimer total(times_, Stage::kTotal);
    const auto start = std::chrono::steady_clock::now();
    const double cpu_start_s = thread_cpu_s();
    note_time(frame.t_ns);
    ++summary_.frames;
    bool frontend_ok = false;
    {
      ScopedStageTimer t(times_, Stage::kFrontend);
      // cam0 rotation between frames from the body rotation: R_c0prev_c0curr = R_c0_b R R_b_c0.
      const Eigen::Quaterniond q_c0prev_c0curr = q_b_c0_.conjugate() * q_bprev_bcurr_ * q_b_c0_;
      const Status st = frontend_.process(frame, have_imu_since_frame_ ? &q_c0prev_c0curr : nullptr,
                                          features_);
      frontend_ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
      q_bprev_bcurr_.setIdentity();
      have_imu_since_frame_ = false;
      frontend_ok = st == Status::kOk;
      if (st == Status::kOk) {
        accumulate_features(*features_);
        const FrontendFrameStats& fs = features_->stats;
        times_->record(Stage::kPyramid, fs.pyramid_ms);
        times_->record(Stage::kDetect, fs.detect_ms);
        times_->record(Stage::kTrack, fs.track_ms);
        times_->record(Stage::kStereo, fs.stereo_ms);
        times_->record(Stage::kRansac, fs.ransac_ms);
      } else {
        ++summary_.frontend_rejected_frames;
      }
    }
    if (frontend_ok && estimator_ != nullptr) {
      EstimatorOutput est;
      EstimatorTiming timing;
      estimator_->add_frame(*features_, &est, &timing);
      times_->record(Stage::kPreintegrate, timing.preintegrate_ms);
      if (est.mode != EstimatorMode::kImuOnly) {
        times_->record(Stage::kSolveRound1, timing.solve_round1_ms);
        times_->record(Stage::kSolveRound2, timing.solve_round2_ms);
      }
      if (est.keyframe) ++summary_.keyframes;
      if (timing.marginalize_ms > 0.0f) times_->record(Stage::kMarginalize, timing.marginalize_ms);
      times_->record(Stage::kBackend, timing.backend_ms);
      backend_ms = timing.backend_ms;
      if (est.valid) {
        if (trajectory_ != nullptr) write_pose(trajectory_, est.t_ns, est.p_w_b, est.q_w_b);
        ++poses_written_;
        if (series_.est_t_s.size() < series_.est_t_s.capacity()) {
          series_.est_t_s.push_back(static_cast<double>(frame.t_ns - first_t_ns_) * 1e-9);
          series_.est_p_w_m.push_back(est.p_w_b);
        }
      }
    }
    summary_.processing_s +=
        std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    summary_.processing_cpu_s += thread_cpu_s() - cpu_start_s;
  }
  if (series_.t_s.size() < series_.t_s.capacity()) {
    const bool ok = frontend_rejected_before_ == summary_.frontend_rejected_frames;
    series_.t_s.push_back(static_cast<double>(frame.t_ns - first_t_ns_) * 1e-9);
    series_.frontend_ms.push_back(frontend_ms);
    series_.backend_ms.push_back(backend_ms);
    series_.total_ms.push_back(
        std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - frame_start).count());
    series_.n_3d.push_back(ok ? features_->n_3d : 0);
    series_.n_2d_left.push_back(ok ? features_->n_2d_left : 0);
    series_.n_2d_right.push_back(ok ? features_->n_2d_right : 0);
  } else {
    ++series_dropped_;
  }
  frontend_rejected_before_ = summary_.frontend_rejected_frames;
  if (steady) summary_.heap_allocs_steady_state += allocs.allocations();
}

void ReplayPipeline::accumulate_features(const FrameFeatures& f) {
  ++frontend_frames_;
  if (f.features.size() > peak_features_) peak_features_ = f.features.size();
  sum_3d_ += f.n_3d;
  sum_2d_left_ += f.n_2d_left;
  sum_2d_right_ += f.n_2d_right;
  for (const FeatureObservation& o : f.features) sum_track_length_ += o.track_length;
  observations_ += static_cast<double>(f.features.size());
  const double rms = f.stats.stereo_epipolar_rms_px;
  sum_sq_epipolar_px_ += rms * rms * f.n_3d;
  epipolar_matches_ += f.n_3d;
}

ReplaySummary ReplayPipeline::summary() const {
  ReplaySummary s = summary_;
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
  w.begin_object("features")
      .value("mean_3d", s.mean_3d, 5)
      .value("mean_2d_left", s.mean_2d_left, 5)
      .value("mean_2d_right", s.mean_2d_right, 5)
      .value("mean_track_length", s.mean_track_length, 5)
      .value("stereo_epipolar_rms_px", s.stereo_epipolar_rms_px, 4)
      .value("keyframes", s.keyframes)
      .end_object();
  w.begin_object("imu").value("saturated_samples", s.saturated_samples).end_object();
  if (estimator_ != nullptr) write_estimator_stats(w);
  w.begin_object("memory")
      .value("heap_allocs_steady_state", summary_.heap_allocs_steady_state)
      .value("static_bytes", static_cast<std::uint64_t>(static_bytes_))
      .value("alloc_counter", alloc_counter_available())
      .begin_object("pools")
      .begin_object("frame_features")
      .value("capacity", static_cast<std::uint64_t>(decltype(FrameFeatures::features)::capacity()))
      .value("peak", static_cast<std::uint64_t>(peak_features_))
      .end_object();
  if (estimator_ != nullptr) {
    const EstimatorStats& e = estimator_->stats();
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
  w.begin_object("drops")
      .value("imu_out_of_order", out_of_order_imu_)
      .value("frontend_rejected_frames", s.frontend_rejected_frames)
      .value("report_series", series_dropped_);
  if (estimator_ != nullptr) {
    const EstimatorStats& e = estimator_->stats();
    w.value("landmarks", e.drops_landmarks)
        .value("visual_residuals", e.drops_residuals)
        .value("imu_interval", e.drops_imu)
        .value("estimator_frames_out_of_order", e.frames_out_of_order)
        .value("mode_changes", e.mode_changes_dropped);
  }
  w.end_object();
}

void ReplayPipeline::write_estimator_stats(JsonWriter& w) const {
  const EstimatorStats& e = estimator_->stats();
  const double t0_ns = static_cast<double>(e.first_frame_t_ns);
  w.begin_object("init")
      .value("success", e.initialized)
      .value("time_s", e.initialized ? (static_cast<double>(e.init_t_ns) - t0_ns) * 1e-9 : -1.0, 4)
      .value("case", e.initialized ? e.init_case : "none")
      .end_object();
  w.begin_array("modes");
  for (const ModeChange& c : e.mode_changes) {
    w.begin_object()
        .value("t_s", (static_cast<double>(c.t_ns) - t0_ns) * 1e-9, 4)
        .value("from", to_string(c.from))
        .value("to", to_string(c.to))
        .value("reason", c.reason)
        .end_object();
  }
  w.end_array();
  w.begin_object("estimator")
      .value("mode", to_string(estimator_->mode()))
      .value("frames_imu_only", e.frames_in_mode[0])
      .value("frames_vo", e.frames_in_mode[1])
      .value("frames_vio", e.frames_in_mode[2])
      .value("poses_written", poses_written_)
      .value("frames_without_pose", e.frames_without_pose)
      .value("solves", e.solves)
      .value("mean_landmarks_in_solve", e.frames_solved > 0 ? e.sum_landmarks_in_solve / static_cast<double>(e.frames_solved) : 0.0, 4)
      .value("mean_2d_in_solve", e.frames_solved > 0 ? e.sum_2d_in_solve / static_cast<double>(e.frames_solved) : 0.0, 4)
      .value("stage_kept_2d_left", e.stage_kept_2d_left)
      .value("stage_added_2d_right", e.stage_added_2d_right)
      .value("stage_3d_sufficient", e.stage_3d_sufficient)
      .value("outlier_landmarks", e.outlier_landmarks)
      .value("second_rounds", e.second_rounds)
      .value("marginalized_old", e.marginalized_old)
      .value("marginalized_second_new", e.marginalized_second_new)
      .value("marginalization_failures", e.marginalization_failures)
      .value("visual_init_failures", e.visual_init_failures)
      .value("align_attempts", e.align_attempts)
      .value("align_failures", e.align_failures)
      .value("align_disagreements", e.align_disagreements)
      .value("imu_samples_held", e.imu_held)
      .value("still_frames", e.still_frames)
      .value("still_rejected_by_vision", e.still_rejected_by_vision)
      .value("resets", e.resets)
      .end_object();
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
  out << "replay: steady-state heap allocations in the pipeline: "
      << summary_.heap_allocs_steady_state << "\n";
}

}  // namespace ums::cli
