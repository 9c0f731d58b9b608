#pragma once
// The board's wrapper around the core pipeline (core/pipeline/vio_pipeline.hpp) that a replay,
// the live app and the sweep push measurements into: options from the AppConfig, the TUM pose
// files, timing per stage, steady-state allocation accounting, the report's per-frame series,
// stats.json and the printed summary. The caller pushes in time order from one thread; with
// two_core the estimator runs on a second thread the pipeline owns (board/host/backend_thread).

#include <cstdint>
#include <cstdio>
#include <memory>
#include <ostream>
#include <vector>

#include "board/config/app_config.hpp"
#include "board/host/backend_thread.hpp"
#include "board/host/tum_pose_sink.hpp"
#include "core/common/measurement_sink.hpp"
#include "core/estimator/estimator.hpp"
#include "core/frontend/frame_features.hpp"
#include "core/pipeline/pose_fanout.hpp"
#include "core/pipeline/vio_pipeline.hpp"
#include "profiling/json_writer.hpp"
#include "profiling/stage_timer.hpp"

namespace ums::cli {

struct ReplayPipelineOptions {
  bool frontend_only = false;      // run the front end and stop there
  // Second BA round bounded by its iteration cap only, not by the wall clock: the same
  // trajectory on any machine however loaded or emulated (the cross-architecture check).
  bool deterministic = false;
  std::size_t report_frames = 0;   // frames of per-frame series kept for report.html (reserved once)
  std::uint64_t steady_state_from_frame = 50;  // frames before this are warm-up for alloc counting
  // The back end of frame k on a second thread while the front end of frame k+1 runs: the
  // estimator gets the same calls in the same order (the same trajectory to the byte with
  // `deterministic`), more frames per second on a board with two free cores. Not with estimate_td.
  bool two_core = false;
};

struct ReplaySummary {
  std::uint64_t frames = 0;
  std::uint64_t imu_samples = 0;
  double duration_s = 0.0;    // data time from the first to the last measurement
  double processing_s = 0.0;  // time spent inside the pipeline (excludes reading and decoding)
  double processing_cpu_s = 0.0;  // CPU time of the pipeline inside it (one core's work; two_core: both threads')
  std::uint64_t heap_allocs_steady_state = 0;
  // Front end, averaged over processed frames.
  double mean_3d = 0.0;
  double mean_2d_left = 0.0;
  double mean_2d_right = 0.0;
  double mean_track_length = 0.0;  // frames, per observation (as the front-end acceptance counts)
  double stereo_epipolar_rms_px = 0.0;  // px, RMS over all accepted 3D matches of the run
  std::uint64_t keyframes = 0;
  std::uint64_t frontend_rejected_frames = 0;  // frames the front end refused (size mismatch, no left)
  std::uint64_t saturated_samples = 0;         // IMU samples the saturation element clipped
};

class ReplayPipeline;

// Stops a pipeline's back-end thread when a scope ends, also by an exception: declared after the
// sinks the pipeline borrows (MAVLink, loop closure), it lets the queued tasks run before they die.
struct BackendStopper {
  ReplayPipeline* pipeline;
  ~BackendStopper();
};

class ReplayPipeline final : public MeasurementSink, private FrameObserver {
 public:
  ReplayPipeline(const AppConfig& config, const ReplayPipelineOptions& options);
  ~ReplayPipeline() override;
  ReplayPipeline(const ReplayPipeline&) = delete;
  ReplayPipeline& operator=(const ReplayPipeline&) = delete;

  void on_imu(const ImuSample& sample) override;
  void on_stereo(const StereoFrame& frame) override;
  // After the last measurement: what the camera-IMU offset still holds goes on, and (two_core)
  // the back end finishes.
  void end_of_input();
  // Runs what the back end's thread still holds and returns to one thread, never throwing: for a
  // caller unwinding after an error, before the sinks it lent (MAVLink, loop closure) are destroyed.
  void stop_backend() noexcept;

  std::uint64_t frames() const { return vio_.counters().frames; }
  void set_static_bytes(std::size_t bytes) { static_bytes_ = bytes; }
  bool has_estimator() const { return vio_.estimator() != nullptr; }
  const Estimator* estimator() const { return vio_.estimator(); }
  // Where one body pose per frame goes (TUM: t_s x y z qx qy qz qw), written as frames are
  // processed; nullptr: nowhere. The caller owns the file.
  void set_trajectory_output(std::FILE* file) {
    vio_.wait_backend();  // two_core: poses_ is the back end's thread's while it runs
    poses_.set_trajectory_output(file);
  }
  // Where the IMU-rate pose goes (same format, one line per IMU sample once a pose exists).
  void set_imu_pose_output(std::FILE* file) {
    vio_.wait_backend();
    poses_.set_imu_pose_output(file);
  }
  // Where the per-frame mode, velocity and biases go (CSV, TumPoseSink::state_header()).
  void set_state_output(std::FILE* file) {
    vio_.wait_backend();
    poses_.set_state_output(file);
  }
  // A live consumer of every pose besides the files (the MAVLink output); not owned.
  void set_pose_consumer(PoseSink* sink) {
    vio_.wait_backend();  // two_core: the fanout is the back end's thread's while it runs
    fanout_.set(1, sink);
  }
  // Keyframe images for later use (none by default); not owned.
  void set_keyframe_image_sink(KeyframeImageSink* sink) { vio_.set_keyframe_image_sink(sink); }
  // Keyframes leaving the window (none by default); not owned.
  void set_keyframe_sink(KeyframeSink* sink) { vio_.set_keyframe_sink(sink); }
  void set_relocation_link(RelocationLink* link) { vio_.set_relocation_link(link); }
  // A third consumer of every pose (loop closure's map-frame poses); not owned.
  void set_map_pose_consumer(PoseSink* sink) {
    vio_.wait_backend();
    fanout_.set(2, sink);
  }
  std::uint64_t poses_written() const { return poses_.poses_written(); }
  const StageTimes& stage_times() const { return *times_; }
  ReplaySummary summary() const;

  // Per-frame series for report.html (the first report_frames frames).
  struct FrameSeries {
    std::vector<double> t_s, frontend_ms, total_ms;
    std::vector<int> n_3d, n_2d_left, n_2d_right;
    std::vector<double> backend_ms;
    std::vector<double> est_t_s;                 // frames with a pose
    std::vector<Eigen::Vector3d> est_p_w_m;      // their positions, m (not aligned)
    std::vector<double> est_td_ms;               // their camera-IMU offset in use, ms
  };
  const FrameSeries& series() const { return series_; }

  // Adds the pipeline's keys to stats.json: frames, imu_samples, duration_s, processing_s,
  // timing_ms, features, imu, memory, drops.
  void write_stats(JsonWriter& w) const;
  void print_summary(std::ostream& out) const;

 private:
  void note_time(std::int64_t t_ns);
  // Each frame once processed (a camera-IMU offset may make it wait for the IMU).
  void on_frame_done(const VioFrameRecord& record, const StereoFrame& frame) override;
  void record_stage_times(const VioFrameRecord& frame);
  void record_series(const VioFrameRecord& rec, const StereoFrame& frame);
  void write_timing_stats(JsonWriter& w) const;
  void write_threads(JsonWriter& w) const;
  void write_memory_stats(JsonWriter& w) const;
  void write_drops(JsonWriter& w, const ReplaySummary& s) const;
  void write_init_and_modes(JsonWriter& w) const;
  void write_estimator_stats(JsonWriter& w) const;
  void write_extrinsic_stats(JsonWriter& w) const;
  void write_time_offset_stats(JsonWriter& w) const;
  void write_gyro_scale_stats(JsonWriter& w) const;
  void write_td_series(JsonWriter& w) const;
  void accumulate_features(const FrameFeatures& f);

  ReplayPipelineOptions options_;
  std::unique_ptr<StageTimes> times_;  // large fixed windows: allocated once here, never per frame
  ReplaySummary summary_;  // the times and allocations measured here; counts come from vio_
  std::int64_t first_t_ns_ = -1;
  std::int64_t last_t_ns_ = -1;

  TumPoseSink poses_;
  PoseFanout fanout_;  // poses_, then the consumer
  std::unique_ptr<BackendThread> backend_;  // two_core only; outlives vio_'s tasks (declared first)
  std::uint64_t backend_allocs_at_steady_ = 0;
  bool steady_seen_ = false;
  VioPipeline vio_;
  double rig_td_s_ = 0.0;  // the configured camera-IMU offset (t_imu = t_cam + td)
  // Running sums for the summary.
  double sum_3d_ = 0.0, sum_2d_left_ = 0.0, sum_2d_right_ = 0.0;
  double sum_track_length_ = 0.0, observations_ = 0.0;
  double sum_sq_epipolar_px_ = 0.0, epipolar_matches_ = 0.0;
  std::uint64_t frontend_frames_ = 0;
  std::size_t peak_features_ = 0;
  FrameSeries series_;
  std::uint64_t series_dropped_ = 0;
  std::size_t static_bytes_ = 0;
};

}  // namespace ums::cli
