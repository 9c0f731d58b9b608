#include "core/pipeline/vio_pipeline.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstring>
#include <stdexcept>

#include "core/math/so3.hpp"

namespace ums {

namespace {

std::int64_t steady_ns() {
  return std::chrono::duration_cast<std::chrono::nanoseconds>(std::chrono::steady_clock::now().time_since_epoch()).count();
}

}  // namespace

VioPipeline::VioPipeline(const VioPipelineOptions& options, const FrontendOptions& frontend,
                         const EstimatorOptions& estimator, const RigCalibration& rig)
    : aligner_(static_cast<std::int64_t>(std::llround(rig.td_s * 1e9)), std::max(rig.cam[0].width, rig.cam[1].width),
               std::max(rig.cam[0].height, rig.cam[1].height), td_range_ns(options, estimator)),
      saturation_(options.saturation),
      frontend_(frontend, rig),
      estimator_(options.frontend_only ? nullptr : new Estimator(estimator, rig)),
      max_width_(std::max(rig.cam[0].width, rig.cam[1].width)),
      max_height_(std::max(rig.cam[0].height, rig.cam[1].height)),
      prev_left_(new std::uint8_t[static_cast<std::size_t>(capacity::kMaxImageWidth) * capacity::kMaxImageHeight]),
      prev_features_(new FrameFeatures()),
      // cam0 in the IMU frame (the gyro's): T_b_i^-1 T_b_c.
      q_b_c0_((rig.imu.T_b_i.inverse() * rig.cam[0].T_b_c).rotation()) {
  for (FrameSlot& slot : slots_) slot.features.reset(new FrameFeatures());
}

VioPipeline::~VioPipeline() {
  // Tasks still queued point at this pipeline: they run first (their errors have nowhere to go).
  try {
    wait_backend();
  } catch (...) {
  }
}

void VioPipeline::set_backend_executor(BackendExecutor* executor) {
  wait_backend();
  if (executor != nullptr && estimator_ != nullptr && estimator_->options().estimate_td) {
    throw std::invalid_argument(
        "VioPipeline: a back-end executor (two cores) needs estimate_td off: frame k's offset estimate "
        "stamps frame k+1 before its front end runs");
  }
  executor_ = executor;
  frontend_slot_ = 0;
  if (executor == nullptr) return;
  const std::size_t image_bytes = static_cast<std::size_t>(max_width_) * static_cast<std::size_t>(max_height_);
  for (FrameSlot& slot : slots_) {
    if (slot.pixels == nullptr) slot.pixels.reset(new std::uint8_t[2 * image_bytes]);
  }
  if (imu_tasks_ == nullptr) imu_tasks_.reset(new ImuTask[kImuTasks]);
}

void VioPipeline::wait_backend() {
  if (executor_ != nullptr) executor_->wait_idle();
}

void VioPipeline::flush() {
  aligner_.flush(&aligned_);
  wait_backend();
}

std::int64_t VioPipeline::td_range_ns(const VioPipelineOptions& options, const EstimatorOptions& estimator) {
  if (options.frontend_only || !estimator.estimate_td) return 0;
  return static_cast<std::int64_t>(std::llround(estimator.td_max_change_ms * 1e6));
}

void VioPipeline::on_imu(const ImuSample& sample) { aligner_.on_imu(sample, &aligned_); }

void VioPipeline::on_stereo(const StereoFrame& frame) { aligner_.on_stereo(frame, &aligned_); }

void VioPipeline::process_imu(const ImuSample& sample) {
  if (!saturation_.plausible(sample)) {
    ++counters_.imu_implausible;  // NaN, Inf or beyond any sensor's range: no reading, dropped
    return;
  }
  if (sample.t_ns <= last_imu_t_ns_) {
    ++counters_.imu_out_of_order;  // a source bug: count, never pass on
    // Stamped before the last sample, not a copy of it: time passed that the stamps do not show.
    if (sample.t_ns < last_imu_t_ns_) ++stepped_back_run_;
    return;
  }
  ImuSample clipped;
  const bool saturated = saturation_.apply(sample, &clipped);
  if (saturated) ++counters_.saturated_samples;
  integrate_hint(sample, clipped);
  const std::int64_t lost_ns = stepped_back_run_ >= 2 ? stepped_back_run_ * imu_period_ns_ : 0;
  if (last_imu_t_ns_ >= 0 && stepped_back_run_ == 0) imu_period_ns_ = std::min(sample.t_ns - last_imu_t_ns_, kMaxImuPeriodNs);
  stepped_back_run_ = 0;
  last_imu_t_ns_ = sample.t_ns;
  ++counters_.imu_samples;
  if (estimator_ == nullptr) return;
  if (executor_ == nullptr) {
    run_imu(clipped, saturated, lost_ns, counters_.frames > 0);
    return;
  }
  const std::size_t index = next_imu_task_;
  next_imu_task_ = (next_imu_task_ + 1) % kImuTasks;
  imu_tasks_[index] = ImuTask{clipped, saturated, lost_ns, counters_.frames > 0};
  executor_->submit(&VioPipeline::imu_task, this, static_cast<std::uint32_t>(index));
}

void VioPipeline::imu_task(void* self, std::uint32_t index) {
  auto* p = static_cast<VioPipeline*>(self);
  const ImuTask& t = p->imu_tasks_[index];
  p->run_imu(t.sample, t.saturated, t.lost_ns, t.after_first_frame);
}

void VioPipeline::run_imu(const ImuSample& sample, bool saturated, std::int64_t lost_ns, bool after_first_frame) {
  if (lost_ns > 0) estimator_->note_lost_imu_time(lost_ns);
  estimator_->add_imu(sample, saturated);
  NavState nav;
  if (pose_sink_ != nullptr && after_first_frame && estimator_->imu_rate_state(&nav)) {
    pose_sink_->on_imu_pose(sample.t_ns, nav);
  }
}

void VioPipeline::integrate_hint(const ImuSample& sample, const ImuSample& clipped) {
  if (last_imu_t_ns_ < 0 || counters_.frames == 0) return;
  // Rotation hint only: raw gyro (bias of a few mrad/s moves KLT starts by < 0.1 px at 20 Hz).
  const double dt_s = static_cast<double>(sample.t_ns - last_imu_t_ns_) * 1e-9;
  q_bprev_bcurr_ = (q_bprev_bcurr_ * so3::exp_quat(clipped.gyro_rad_s * dt_s)).normalized();
  have_imu_since_frame_ = true;
}

void VioPipeline::process_stereo(const StereoFrame& f) {
  FrameSlot& slot = slots_[frontend_slot_];
  slot.start_ns = steady_ns();
  ++counters_.frames;
  slot.record = VioFrameRecord{};
  slot.record.t_ns = f.t_ns;
  run_frontend(f, &slot);
  if (executor_ == nullptr) {
    run_backend(frontend_slot_, f);
    return;
  }
  copy_frame(f, &slot);  // the source owns f's pixels only during this call
  // The previous frame's back end (and the IMU after it) is done with the other slot when this
  // returns, so the next front end may fill it; this frame's back end then overlaps that front end.
  executor_->wait_idle();
  executor_->submit(&VioPipeline::frame_task, this, static_cast<std::uint32_t>(frontend_slot_));
  frontend_slot_ = 1 - frontend_slot_;
}

void VioPipeline::run_frontend(const StereoFrame& frame, FrameSlot* slot) {
  const auto start = std::chrono::steady_clock::now();
  // cam0 rotation between frames from the body rotation: R_c0prev_c0curr = R_c0_b R R_b_c0.
  const Eigen::Quaterniond q_c0prev_c0curr = q_b_c0_.conjugate() * q_bprev_bcurr_ * q_b_c0_;
  slot->record.frontend_status =
      frontend_.process(frame, have_imu_since_frame_ ? &q_c0prev_c0curr : nullptr, slot->features.get());
  slot->record.frontend_ms =
      std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
  q_bprev_bcurr_.setIdentity();
  have_imu_since_frame_ = false;
  if (slot->record.frontend_status != Status::kOk) ++counters_.frontend_rejected_frames;
}

void VioPipeline::copy_frame(const StereoFrame& frame, FrameSlot* slot) const {
  const std::size_t image_bytes = static_cast<std::size_t>(max_width_) * static_cast<std::size_t>(max_height_);
  slot->frame = frame;
  auto copy = [&](const ImageView& v, std::uint8_t* dst) {
    // A size beyond the calibration was refused by the front end: no pixels for the back end.
    if (!v.valid() || v.width > max_width_ || v.height > max_height_) return ImageView{};
    return copy_packed(v, dst);
  };
  slot->frame.left = copy(frame.left, slot->pixels.get());
  slot->frame.right = copy(frame.right, slot->pixels.get() + image_bytes);
}

void VioPipeline::frame_task(void* self, std::uint32_t slot) {
  auto* p = static_cast<VioPipeline*>(self);
  p->run_backend(static_cast<int>(slot), p->slots_[slot].frame);
}

void VioPipeline::run_backend(int slot, const StereoFrame& frame) {
  backend_slot_ = slot;
  record_ = slots_[slot].record;
  if (record_.frontend_status == Status::kOk && estimator_ != nullptr) run_estimator(frame);
  record_.total_ms = static_cast<double>(steady_ns() - slots_[slot].start_ns) * 1e-6;
  if (frame_observer_ != nullptr) frame_observer_->on_frame_done(record_, frame);
}

void VioPipeline::run_estimator(const StereoFrame& frame) {
  const std::uint64_t refused_before = estimator_->stats().frames_out_of_order;
  const FrameFeatures& features = *slots_[backend_slot_].features;
  estimator_->add_frame(features, &record_.estimate, &record_.timing);
  record_.estimated = true;
  const EstimatorOutput& est = record_.estimate;
  if (est.keyframe) ++counters_.keyframes;
  // The next frames are stamped with the offset as now estimated (held at the calibration
  // without estimate_td): the window then models only what is left of it. (Not with an
  // executor: estimate_td is refused there, and the aligner is the front end's thread's.)
  if (executor_ == nullptr) aligner_.set_td_ns(static_cast<std::int64_t>(std::llround(est.td_s * 1e9)));
  if (est.valid && pose_sink_ != nullptr) pose_sink_->on_frame_pose(est);
  // A frame the estimator refused (out of order) repeats the previous output: nothing settled.
  const bool processed = estimator_->stats().frames_out_of_order == refused_before;
  if (processed && keyframe_sink_ != nullptr) hand_on_settled(est, frame);
}

void VioPipeline::hand_on_settled(const EstimatorOutput& est, const StereoFrame& frame) {
  if (est.settled_frame != kNoFrame && est.settled_frame == prev_id_) {
    keyframe_sink_->on_keyframe_image(prev_id_, prev_t_ns_, prev_view_, *prev_features_);
  }
  // Keep this frame: the next frame's slide decides whether it stays in the window.
  prev_id_ = kNoFrame;
  const ImageView& left = frame.left;
  if (!left.valid() || left.width > capacity::kMaxImageWidth || left.height > capacity::kMaxImageHeight) return;
  prev_view_ = copy_packed(left, prev_left_.get());
  *prev_features_ = *slots_[backend_slot_].features;
  prev_id_ = est.frame_id;
  prev_t_ns_ = est.t_ns;
}

}  // namespace ums
