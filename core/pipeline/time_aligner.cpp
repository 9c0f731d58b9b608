#include "core/pipeline/time_aligner.hpp"

#include <cstring>

namespace ums {

TimeAligner::TimeAligner(std::int64_t td_ns, int max_width, int max_height) : td_ns_(td_ns) {
  if (td_ns_ < 0) held_imu_ = std::make_unique<RingBuffer<ImuSample, capacity::kHeldImuSamples>>();
  if (td_ns_ > 0) {
    image_bytes_ = static_cast<std::size_t>(max_width) * static_cast<std::size_t>(max_height);
    left_ = std::make_unique<std::uint8_t[]>(image_bytes_);
    right_ = std::make_unique<std::uint8_t[]>(image_bytes_);
  }
}

void TimeAligner::on_imu(const ImuSample& sample, MeasurementSink* out) {
  if (frame_held_ && sample.t_ns > held_frame_.t_ns) {  // a sample at its time goes first (ties: IMU first)
    frame_held_ = false;
    out->on_stereo(held_frame_);
  }
  if (sample.t_ns > newest_imu_t_ns_) newest_imu_t_ns_ = sample.t_ns;
  if (held_imu_ == nullptr) {
    out->on_imu(sample);
    if (frame_held_ && sample.t_ns == held_frame_.t_ns) {  // the IMU is at its time now
      frame_held_ = false;
      out->on_stereo(held_frame_);
    }
    return;
  }
  if (held_imu_->full()) {
    ImuSample oldest;
    held_imu_->pop(&oldest);
    ++counters_.imu_released_early;
    out->on_imu(oldest);
  }
  held_imu_->push(sample);
  release_imu_until(newest_imu_t_ns_ + td_ns_, out);  // what |td| has passed
}

void TimeAligner::on_stereo(const StereoFrame& frame, MeasurementSink* out) {
  StereoFrame f = frame;
  f.t_ns += td_ns_;
  if (frame_held_) {  // the IMU never reached it before the next frame: td too large
    frame_held_ = false;
    ++counters_.frames_unaligned;
    out->on_stereo(held_frame_);
  }
  if (held_imu_ != nullptr) release_imu_until(f.t_ns, out);
  if (td_ns_ > 0 && f.left.valid() && newest_imu_t_ns_ < f.t_ns && fits(f)) {
    hold_frame(f);
    return;
  }
  out->on_stereo(f);
}

void TimeAligner::flush(MeasurementSink* out) {
  if (held_imu_ != nullptr) release_imu_until(INT64_MAX, out);
  if (frame_held_) {
    frame_held_ = false;
    ++counters_.frames_unaligned;
    out->on_stereo(held_frame_);
  }
}

void TimeAligner::release_imu_until(std::int64_t t_ns, MeasurementSink* out) {
  while (!held_imu_->empty() && held_imu_->front().t_ns <= t_ns) {
    ImuSample s;
    held_imu_->pop(&s);
    out->on_imu(s);
  }
}

bool TimeAligner::fits(const StereoFrame& f) const {
  for (const ImageView* v : {&f.left, &f.right}) {
    if (v->valid() && static_cast<std::size_t>(v->width) * static_cast<std::size_t>(v->height) > image_bytes_) return false;
  }
  return true;
}

void TimeAligner::hold_frame(const StereoFrame& f) {
  const ImageView* in[2] = {&f.left, &f.right};
  std::uint8_t* copy[2] = {left_.get(), right_.get()};
  ImageView* view[2] = {&held_frame_.left, &held_frame_.right};
  held_frame_ = f;
  for (int c = 0; c < 2; ++c) {
    const ImageView& v = *in[c];
    if (!v.valid()) {
      *view[c] = ImageView{};  // missing (a right-camera dropout)
      continue;
    }
    for (int y = 0; y < v.height; ++y) std::memcpy(copy[c] + static_cast<std::size_t>(y) * v.width, v.row(y), v.width);
    *view[c] = ImageView{copy[c], v.width, v.height, v.width};
  }
  frame_held_ = true;
  ++counters_.frames_held;
}

}  // namespace ums
