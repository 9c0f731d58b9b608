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
//
// Two cores: with a BackendExecutor set, everything after the front end (the estimator, poses,
// the frame observer, keyframe images and keyframes) runs as the executor's tasks, in the order
// a single thread would run it, so the front end of frame k+1 overlaps the back end of frame k
// and the results are the same. The frame's pixels are then copied for its back end (the source
// owns them only during on_stereo). Sinks and the observer are called from the executor's thread;
// last_frame(), features(), counters().keyframes and estimator() are then valid in those calls and
// after flush().

#include <cstdint>
#include <memory>

#include <Eigen/Geometry>

#include "core/common/calibration.hpp"
#include "core/common/capacity.hpp"
#include "core/common/measurement_sink.hpp"
#include "core/common/status.hpp"
#include "core/estimator/estimator.hpp"
#include "core/frontend/frame_features.hpp"
#include "core/frontend/frontend.hpp"
#include "core/imu/saturation.hpp"
#include "core/pipeline/backend_executor.hpp"
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
  // End of the input: a frame or IMU samples still held for the camera-IMU offset go on (and,
  // with an executor, their back end has run when this returns).
  void flush();

  // Start-up, before the first push: the back end's tasks go to executor (not owned; nullptr:
  // inline). Allocates the frame copies. std::invalid_argument with estimate_td, whose estimate
  // of frame k stamps frame k+1 before its front end runs: the stages cannot overlap.
  void set_backend_executor(BackendExecutor* executor);
  // With an executor: returns once every back-end task so far has run (then the sinks may be
  // swapped and the back end's results read); rethrows a task's exception. Inline: nothing to do.
  void wait_backend();

  // Not owned; nullptr: the output is not produced. Set between pushes.
  void set_pose_sink(PoseSink* sink) {
    wait_backend();
    pose_sink_ = sink;
  }
  void set_keyframe_image_sink(KeyframeImageSink* sink) {
    wait_backend();
    keyframe_sink_ = sink;
  }
  void set_frame_observer(FrameObserver* observer) {
    wait_backend();
    frame_observer_ = observer;
  }
  // The estimator's marginalized keyframes (no effect with frontend_only).
  void set_keyframe_sink(KeyframeSink* sink) {
    wait_backend();
    if (estimator_ != nullptr) estimator_->set_keyframe_sink(sink);
  }
  // Tightly coupled relocation's requests and results (no effect with frontend_only).
  void set_relocation_link(RelocationLink* link) {
    wait_backend();
    if (estimator_ != nullptr) estimator_->set_relocation_link(link);
  }

  const Estimator* estimator() const { return estimator_.get(); }  // nullptr with frontend_only
  const VioPipelineCounters& counters() const { return counters_; }
  const TimeAlignerCounters& time_alignment() const { return aligner_.counters(); }
  std::int64_t applied_td_ns() const { return aligner_.td_ns(); }  // the offset new frames get
  const VioFrameRecord& last_frame() const { return record_; }  // the last frame processed
  // The last processed frame's (frontend_status kOk).
  const FrameFeatures& features() const { return *slots_[backend_slot_].features; }

 private:
  // What leaves the TimeAligner: IMU-time order, frames on the IMU clock.
  struct Aligned final : MeasurementSink {
    explicit Aligned(VioPipeline* p) : pipeline(p) {}
    void on_imu(const ImuSample& sample) override { pipeline->process_imu(sample); }
    void on_stereo(const StereoFrame& frame) override { pipeline->process_stereo(frame); }
    VioPipeline* pipeline;
  };
  // A frame between its front end and its back end: its features, what the front end recorded
  // and, with an executor, a copy of its pixels (two slots: the front end fills one while the back
  // end of the previous frame reads the other).
  struct FrameSlot {
    std::unique_ptr<FrameFeatures> features;
    VioFrameRecord record;
    std::int64_t start_ns = 0;  // steady clock at the frame's arrival
    StereoFrame frame;          // views into pixels (executor only)
    std::unique_ptr<std::uint8_t[]> pixels;
  };
  // An IMU sample on its way to the estimator (executor only).
  struct ImuTask {
    ImuSample sample;   // as clipped by the saturation element
    bool saturated = false;
    std::int64_t lost_ns = 0;
    bool after_first_frame = false;
  };
  static constexpr std::size_t kImuTasks = capacity::kBackendTasks + 2;  // never one still waiting

  static std::int64_t td_range_ns(const VioPipelineOptions& options, const EstimatorOptions& estimator);
  static void frame_task(void* self, std::uint32_t slot);
  static void imu_task(void* self, std::uint32_t index);
  void process_imu(const ImuSample& sample);
  void process_stereo(const StereoFrame& frame_imu_clock);
  void integrate_hint(const ImuSample& sample, const ImuSample& clipped);
  void run_frontend(const StereoFrame& frame, FrameSlot* slot);
  void copy_frame(const StereoFrame& frame, FrameSlot* slot) const;
  void run_backend(int slot, const StereoFrame& frame);
  void run_imu(const ImuSample& sample, bool saturated, std::int64_t lost_ns, bool after_first_frame);
  void run_estimator(const StereoFrame& frame);
  void hand_on_settled(const EstimatorOutput& est, const StereoFrame& frame);

  TimeAligner aligner_;  // rig td_s: t_imu = t_cam + td
  Aligned aligned_{this};
  SaturationElement saturation_;
  Frontend frontend_;
  std::unique_ptr<Estimator> estimator_;
  FrameSlot slots_[2];       // features allocated once; pixels with an executor
  int frontend_slot_ = 0;    // the slot the next front end fills (always 0 without an executor)
  int backend_slot_ = 0;     // the slot of the frame whose back end ran last
  BackendExecutor* executor_ = nullptr;
  int max_width_ = 0, max_height_ = 0;  // px, the largest calibrated image (frame copies)
  std::unique_ptr<ImuTask[]> imu_tasks_;  // kImuTasks, with an executor
  std::size_t next_imu_task_ = 0;
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
