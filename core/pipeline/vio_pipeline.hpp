#pragma once
// The processing pipeline of one stereo-inertial stream: what every source (replay, simulator,
// D455) pushes into and what every program (replay, live, sweep) runs.
//
//   on_imu:    plausibility (finite, in range) -> time order check -> saturation element -> gyro rotation hint -> Estimator::add_imu
//              -> PoseSink::on_imu_pose (once a pose exists)
//   (both through TimeAligner first: + rig td_s, the only place the camera-IMU offset is applied,
//   and IMU-time order restored when td_s is not 0; with estimate_td each processed frame moves
//   the offset for the next ones to the estimator's, within td_max_change_ms of td_s)
//   on_stereo: Frontend (with the
//              hint) -> Estimator::add_frame -> PoseSink::on_frame_pose (when valid),
//              KeyframeImageSink::on_keyframe_image (the previous frame, when this frame's window
//              slide made it permanent: EstimatorOutput::settled_frame)
//
// It owns the saturation element, the front end, the estimator (none when frontend_only), one
// frame's features and, while a keyframe image sink is set, a copy of the previous frame's left
// image and features (the frame a window slide may settle), all allocated in the constructor; on_imu / on_stereo allocate nothing. It
// owns no thread, no file and no clock of its own (the board times and counts around it); the
// caller pushes in time order from one thread. What the last frame did (status, features, the
// estimate, stage timings) stays readable until the next on_stereo.

#include <cstdint>
#include <memory>

#include <Eigen/Geometry>

#include "core/common/calibration.hpp"
#include "core/common/measurement_sink.hpp"
#include "core/common/status.hpp"
#include "core/estimator/estimator.hpp"
#include "core/frontend/frame_features.hpp"
#include "core/frontend/frontend.hpp"
#include "core/imu/saturation.hpp"
#include "core/pipeline/keyframe_image_sink.hpp"
#include "core/pipeline/pose_sink.hpp"
#include "core/pipeline/time_aligner.hpp"

namespace ums {

struct VioPipelineOptions {
  bool frontend_only = false;      // run the front end and stop there (no estimator, no poses)
  SaturationOptions saturation;    // the IMU saturation element ahead of everything else
};

// What one frame did (a frame is processed in on_stereo, or in a later on_imu when a positive
// camera-IMU offset makes it wait for the IMU: see FrameObserver).
struct VioFrameRecord {
  std::int64_t t_ns = 0;                   // the frame's time on the IMU clock (stamp + td_s)
  Status frontend_status = Status::kOk;    // kOk: features() holds this frame's features
  double frontend_ms = 0.0;                // ms, wall time of Frontend::process
  bool estimated = false;                  // the estimator ran: estimate and timing are this frame's
  EstimatorOutput estimate;
  EstimatorTiming timing;
  double total_ms = 0.0;                   // ms, wall time of the whole frame in the pipeline
};

// Told of every frame once it has been processed, in order (the board's series and stage times).
class FrameObserver {
 public:
  virtual ~FrameObserver() = default;
  // frame: on the IMU clock; its images and the record are valid during the call.
  virtual void on_frame_done(const VioFrameRecord& record, const StereoFrame& frame) = 0;
};

struct VioPipelineCounters {
  std::uint64_t frames = 0;                    // stereo frames pushed
  std::uint64_t imu_samples = 0;               // IMU samples passed on
  std::uint64_t imu_out_of_order = 0;          // not after the previous sample: dropped (a source bug)
  std::uint64_t saturated_samples = 0;         // clipped by the saturation element
  std::uint64_t imu_implausible = 0;           // not finite or beyond the sensor range: dropped
  std::uint64_t frontend_rejected_frames = 0;  // refused by the front end (size mismatch, no left)
  std::uint64_t keyframes = 0;                 // estimates that said keyframe
};

class VioPipeline final : public MeasurementSink {
 public:
  // Start-up: the front end and the estimator validate their options (std::invalid_argument)
  // and allocate every buffer here.
  VioPipeline(const VioPipelineOptions& options, const FrontendOptions& frontend,
              const EstimatorOptions& estimator, const RigCalibration& rig);
  ~VioPipeline() override;
  VioPipeline(const VioPipeline&) = delete;
  VioPipeline& operator=(const VioPipeline&) = delete;

  void on_imu(const ImuSample& sample) override;
  void on_stereo(const StereoFrame& frame) override;
  // End of the input: a frame or IMU samples still held for the camera-IMU offset go on.
  void flush() { aligner_.flush(&aligned_); }

  // Not owned; nullptr: the output is not produced. Set between pushes.
  void set_pose_sink(PoseSink* sink) { pose_sink_ = sink; }
  void set_keyframe_image_sink(KeyframeImageSink* sink) { keyframe_sink_ = sink; }
  void set_frame_observer(FrameObserver* observer) { frame_observer_ = observer; }
  // The estimator's marginalized keyframes (no effect with frontend_only).
  void set_keyframe_sink(KeyframeSink* sink) {
    if (estimator_ != nullptr) estimator_->set_keyframe_sink(sink);
  }
  // Tightly coupled relocation's requests and results (no effect with frontend_only).
  void set_relocation_link(RelocationLink* link) {
    if (estimator_ != nullptr) estimator_->set_relocation_link(link);
  }

  const Estimator* estimator() const { return estimator_.get(); }  // nullptr with frontend_only
  const VioPipelineCounters& counters() const { return counters_; }
  const TimeAlignerCounters& time_alignment() const { return aligner_.counters(); }
  std::int64_t applied_td_ns() const { return aligner_.td_ns(); }  // the offset new frames get
  const VioFrameRecord& last_frame() const { return record_; }  // the last frame processed
  const FrameFeatures& features() const { return *features_; }  // the last frame's (frontend_status kOk)

 private:
  // What leaves the TimeAligner: IMU-time order, frames on the IMU clock.
  struct Aligned final : MeasurementSink {
    explicit Aligned(VioPipeline* p) : pipeline(p) {}
    void on_imu(const ImuSample& sample) override { pipeline->process_imu(sample); }
    void on_stereo(const StereoFrame& frame) override { pipeline->process_stereo(frame); }
    VioPipeline* pipeline;
  };
  static std::int64_t td_range_ns(const VioPipelineOptions& options, const EstimatorOptions& estimator);
  void process_imu(const ImuSample& sample);
  void process_stereo(const StereoFrame& frame_imu_clock);
  void integrate_hint(const ImuSample& sample, const ImuSample& clipped);
  void run_frontend(const StereoFrame& frame);
  void run_estimator(const StereoFrame& frame);
  void hand_on_settled(const EstimatorOutput& est, const StereoFrame& frame);

  TimeAligner aligner_;  // rig td_s: t_imu = t_cam + td
  Aligned aligned_{this};
  SaturationElement saturation_;
  Frontend frontend_;
  std::unique_ptr<Estimator> estimator_;
  std::unique_ptr<FrameFeatures> features_;  // one frame's features, allocated once
  FrameObserver* frame_observer_ = nullptr;
  PoseSink* pose_sink_ = nullptr;
  KeyframeImageSink* keyframe_sink_ = nullptr;
  // The previous frame, kept for the keyframe image sink.
  std::unique_ptr<std::uint8_t[]> prev_left_;
  std::unique_ptr<FrameFeatures> prev_features_;
  ImageView prev_view_;
  FrameId prev_id_ = kNoFrame;
  std::int64_t prev_t_ns_ = 0;
  VioPipelineCounters counters_;
  VioFrameRecord record_;
  std::int64_t last_imu_t_ns_ = -1;
  // A clock stepped back: the samples stamped before the last one are dropped, but real time
  // passed with them, one sample period each (the last step, at most kMaxImuPeriodNs), which the
  // estimator's next interval is told about. A single such sample is a pair delivered out of
  // order (its time lies inside the stamps already seen): a run of two at least.
  static constexpr std::int64_t kMaxImuPeriodNs = 50'000'000;
  std::int64_t imu_period_ns_ = 0;
  std::int64_t stepped_back_run_ = 0;
  // Gyro-integrated rotation of the body since the previous frame: the front end's KLT hint.
  Eigen::Quaterniond q_bprev_bcurr_ = Eigen::Quaterniond::Identity();
  Eigen::Quaterniond q_b_c0_ = Eigen::Quaterniond::Identity();
  bool have_imu_since_frame_ = false;
};

}  // namespace ums
