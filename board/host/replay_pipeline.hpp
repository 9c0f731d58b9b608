#pragma once
// The pipeline a replay (and later the live app) pushes measurements into: timing per stage,
// steady-state allocation accounting and the stages that exist. It owns no threads; the caller
// pushes in time order.

#include <cstdint>
#include <cstdio>
#include <memory>
#include <ostream>
#include <vector>

#include "board/config/app_config.hpp"
#include "core/common/measurement_sink.hpp"
#include "core/frontend/frame_features.hpp"
#include "core/frontend/frontend.hpp"
#include "core/estimator/estimator.hpp"
#include "core/imu/saturation.hpp"
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
};

struct ReplaySummary {
  std::uint64_t frames = 0;
  std::uint64_t imu_samples = 0;
  double duration_s = 0.0;    // data time from the first to the last measurement
  double processing_s = 0.0;  // time spent inside the pipeline (excludes reading and decoding)
  double processing_cpu_s = 0.0;  // CPU time of the pipeline's thread inside it (one core's work)
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

class ReplayPipeline final : public MeasurementSink {
 public:
  ReplayPipeline(const AppConfig& config, const ReplayPipelineOptions& options);
  ~ReplayPipeline() override;

  void on_imu(const ImuSample& sample) override;
  void on_stereo(const StereoFrame& frame) override;

  std::uint64_t frames() const { return summary_.frames; }
  void set_static_bytes(std::size_t bytes) { static_bytes_ = bytes; }
  bool has_estimator() const { return estimator_ != nullptr; }
  const Estimator* estimator() const { return estimator_.get(); }
  // Where one body pose per frame goes (TUM: t_s x y z qx qy qz qw), written as frames are
  // processed; nullptr: nowhere. The caller owns the file.
  void set_trajectory_output(std::FILE* file) { trajectory_ = file; }
  // Where the IMU-rate pose goes (same format, one line per IMU sample once a pose exists).
  void set_imu_pose_output(std::FILE* file) { imu_poses_ = file; }
  std::uint64_t poses_written() const { return poses_written_; }
  const StageTimes& stage_times() const { return *times_; }
  ReplaySummary summary() const;

  // Per-frame series for report.html (the first report_frames frames).
  struct FrameSeries {
    std::vector<double> t_s, frontend_ms, total_ms;
    std::vector<int> n_3d, n_2d_left, n_2d_right;
    std::vector<double> backend_ms;
    std::vector<double> est_t_s;                 // frames with a pose
    std::vector<Eigen::Vector3d> est_p_w_m;      // their positions, m (not aligned)
  };
  const FrameSeries& series() const { return series_; }

  // Adds the pipeline's keys to stats.json: frames, imu_samples, duration_s, processing_s,
  // timing_ms, features, imu, memory, drops.
  void write_stats(JsonWriter& w) const;
  void print_summary(std::ostream& out) const;

 private:
  void note_time(std::int64_t t_ns);
  void write_estimator_stats(JsonWriter& w) const;
  void accumulate_features(const FrameFeatures& f);

  AppConfig config_;
  ReplayPipelineOptions options_;
  StageTimes* times_;  // large fixed windows: allocated once here, never per frame
  ReplaySummary summary_;
  std::int64_t first_t_ns_ = -1;
  std::int64_t last_t_ns_ = -1;
  std::int64_t last_imu_t_ns_ = -1;
  std::uint64_t out_of_order_imu_ = 0;

  SaturationElement saturation_;
  Frontend frontend_;
  std::unique_ptr<Estimator> estimator_;  // null with frontend_only
  std::FILE* trajectory_ = nullptr;
  std::FILE* imu_poses_ = nullptr;
  std::uint64_t poses_written_ = 0;
  FrameFeatures* features_;  // one frame's features, allocated once
  // Gyro-integrated rotation of the body since the previous frame: the front end's KLT hint.
  Eigen::Quaterniond q_bprev_bcurr_ = Eigen::Quaterniond::Identity();
  Eigen::Quaterniond q_b_c0_ = Eigen::Quaterniond::Identity();
  bool have_imu_since_frame_ = false;
  // Running sums for the summary.
  double sum_3d_ = 0.0, sum_2d_left_ = 0.0, sum_2d_right_ = 0.0;
  double sum_track_length_ = 0.0, observations_ = 0.0;
  double sum_sq_epipolar_px_ = 0.0, epipolar_matches_ = 0.0;
  std::uint64_t frontend_frames_ = 0;
  std::size_t peak_features_ = 0;
  FrameSeries series_;
  std::uint64_t series_dropped_ = 0;
  std::uint64_t frontend_rejected_before_ = 0;
  std::size_t static_bytes_ = 0;
};

}  // namespace ums::cli
