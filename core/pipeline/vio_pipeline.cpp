#include "core/pipeline/vio_pipeline.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstring>

#include "core/math/so3.hpp"

namespace ums {

VioPipeline::VioPipeline(const VioPipelineOptions& options, const FrontendOptions& frontend,
                         const EstimatorOptions& estimator, const RigCalibration& rig)
    : aligner_(static_cast<std::int64_t>(std::llround(rig.td_s * 1e9)), std::max(rig.cam[0].width, rig.cam[1].width),
               std::max(rig.cam[0].height, rig.cam[1].height), td_range_ns(options, estimator)),
      saturation_(options.saturation),
      frontend_(frontend, rig),
      estimator_(options.frontend_only ? nullptr : new Estimator(estimator, rig)),
      features_(new FrameFeatures()),
      prev_left_(new std::uint8_t[static_cast<std::size_t>(capacity::kMaxImageWidth) * capacity::kMaxImageHeight]),
      prev_features_(new FrameFeatures()),
      // cam0 in the IMU frame (the gyro's): T_b_i^-1 T_b_c.
      q_b_c0_((rig.imu.T_b_i.inverse() * rig.cam[0].T_b_c).rotation()) {}

VioPipeline::~VioPipeline() = default;

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
  if (lost_ns > 0) estimator_->note_lost_imu_time(lost_ns);
  estimator_->add_imu(clipped, saturated);
  NavState nav;
  if (pose_sink_ != nullptr && counters_.frames > 0 && estimator_->imu_rate_state(&nav)) {
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
  const auto start = std::chrono::steady_clock::now();
  ++counters_.frames;
  record_ = VioFrameRecord{};
  record_.t_ns = f.t_ns;
  run_frontend(f);
  if (record_.frontend_status == Status::kOk && estimator_ != nullptr) run_estimator(f);
  record_.total_ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
  if (frame_observer_ != nullptr) frame_observer_->on_frame_done(record_, f);
}

void VioPipeline::run_frontend(const StereoFrame& frame) {
  const auto start = std::chrono::steady_clock::now();
  // cam0 rotation between frames from the body rotation: R_c0prev_c0curr = R_c0_b R R_b_c0.
  const Eigen::Quaterniond q_c0prev_c0curr = q_b_c0_.conjugate() * q_bprev_bcurr_ * q_b_c0_;
  record_.frontend_status =
      frontend_.process(frame, have_imu_since_frame_ ? &q_c0prev_c0curr : nullptr, features_.get());
  record_.frontend_ms =
      std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
  q_bprev_bcurr_.setIdentity();
  have_imu_since_frame_ = false;
  if (record_.frontend_status != Status::kOk) ++counters_.frontend_rejected_frames;
}

void VioPipeline::run_estimator(const StereoFrame& frame) {
  const std::uint64_t refused_before = estimator_->stats().frames_out_of_order;
  estimator_->add_frame(*features_, &record_.estimate, &record_.timing);
  record_.estimated = true;
  const EstimatorOutput& est = record_.estimate;
  if (est.keyframe) ++counters_.keyframes;
  // The next frames are stamped with the offset as now estimated (held at the calibration
  // without estimate_td): the window then models only what is left of it.
  aligner_.set_td_ns(static_cast<std::int64_t>(std::llround(est.td_s * 1e9)));
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
  for (int y = 0; y < left.height; ++y) {
    std::memcpy(prev_left_.get() + static_cast<std::size_t>(y) * static_cast<std::size_t>(left.width), left.row(y),
                static_cast<std::size_t>(left.width));
  }
  prev_view_ = ImageView{prev_left_.get(), left.width, left.height, left.width};
  *prev_features_ = *features_;
  prev_id_ = est.frame_id;
  prev_t_ns_ = est.t_ns;
}

}  // namespace ums
