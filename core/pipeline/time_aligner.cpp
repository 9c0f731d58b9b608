#include "core/pipeline/time_aligner.hpp"

#include <algorithm>
#include <cstring>

namespace ums {

TimeAligner::TimeAligner(std::int64_t td_ns, int max_width, int max_height, std::int64_t range_ns)
    : td0_ns_(td_ns), range_ns_(std::max<std::int64_t>(range_ns, 0)), td_ns_(td_ns) {
  if (td0_ns_ - range_ns_ < 0) held_imu_ = std::make_unique<RingBuffer<ImuSample, capacity::kHeldImuSamples>>();
  if (td0_ns_ + range_ns_ > 0) {
    image_bytes_ = static_cast<std::size_t>(max_width) * static_cast<std::size_t>(max_height);
    left_ = std::make_unique<std::uint8_t[]>(image_bytes_);
    right_ = std::make_unique<std::uint8_t[]>(image_bytes_);
  }
}

std::int64_t TimeAligner::set_td_ns(std::int64_t td_ns) {
  td_ns_ = std::clamp(td_ns, td0_ns_ - range_ns_, td0_ns_ + range_ns_);
  return td_ns_;
}

void TimeAligner::on_imu(const ImuSample& sample, MeasurementSink* out) {
  if (frame_held_ && sample.t_ns > held_frame_.t_ns) {  // a sample past its time: the frame goes first
    if (held_imu_ != nullptr) release_imu_until(held_frame_.t_ns, out);
    emit_held_frame(out);
  }
  if (sample.t_ns > newest_imu_t_ns_) newest_imu_t_ns_ = sample.t_ns;
  if (held_imu_ == nullptr || (td_ns_ >= 0 && held_imu_->empty())) {
    emit_imu(sample, out);
  } else {
    if (held_imu_->full()) {
      ImuSample oldest;
      held_imu_->pop(&oldest);
      ++counters_.imu_released_early;
      emit_imu(oldest, out);
    }
    held_imu_->push(sample);
    release_imu_until(newest_imu_t_ns_ + std::min<std::int64_t>(td_ns_, 0), out);  // what |td| has passed
  }
  if (frame_held_ && released_imu_t_ns_ >= held_frame_.t_ns) emit_held_frame(out);  // the IMU is at its time
}

void TimeAligner::on_stereo(const StereoFrame& frame, MeasurementSink* out) {
  StereoFrame f = frame;
  f.t_ns += td_ns_;
  f.td_ns = td_ns_;
  if (frame_held_) {  // the IMU never reached it before the next frame: td too large
    ++counters_.frames_unaligned;
    emit_held_frame(out);
  }
  if (held_imu_ != nullptr) release_imu_until(f.t_ns, out);
  if (range_ns_ > 0 && td_ns_ < 0 && f.t_ns < released_imu_t_ns_) {
    // Samples went on under a larger offset than this frame's: it cannot go before them.
    f.t_ns = released_imu_t_ns_;
    f.td_ns = f.t_ns - frame.t_ns;
    ++counters_.frames_restamped;
  }
  if (left_ != nullptr && f.left.valid() && newest_imu_t_ns_ < f.t_ns && fits(f)) {
    hold_frame(f);
    return;
  }
  out->on_stereo(f);
}

void TimeAligner::flush(MeasurementSink* out) {
  if (held_imu_ != nullptr) release_imu_until(INT64_MAX, out);
  if (frame_held_) {
    ++counters_.frames_unaligned;
    emit_held_frame(out);
  }
}

void TimeAligner::release_imu_until(std::int64_t t_ns, MeasurementSink* out) {
  while (!held_imu_->empty() && held_imu_->front().t_ns <= t_ns) {
    ImuSample s;
    held_imu_->pop(&s);
    emit_imu(s, out);
  }
}

void TimeAligner::emit_imu(const ImuSample& sample, MeasurementSink* out) {
  if (sample.t_ns > released_imu_t_ns_) released_imu_t_ns_ = sample.t_ns;
  out->on_imu(sample);
}

void TimeAligner::emit_held_frame(MeasurementSink* out) {
  frame_held_ = false;
  out->on_stereo(held_frame_);
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
    *view[c] = copy_packed(v, copy[c]);
  }
  frame_held_ = true;
  ++counters_.frames_held;
}

}  // namespace ums
