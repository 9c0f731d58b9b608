#include "core/estimator/imu_buffer.hpp"

namespace ums {

ImuBuffer::ImuBuffer(std::int64_t max_gap_ns)
    : recent_(std::make_unique<RingBuffer<ImuSample, kRecent>>()), scratch_(new ImuSample[kRecent]),
      max_gap_ns_(max_gap_ns) {}

ImuBuffer::Added ImuBuffer::add(const ImuSample& in, bool saturated) {
  Added a;
  if (have_ && in.t_ns <= last_.t_ns) return a;
  a.accepted = true;
  a.first = !have_;
  a.after_gap = have_ && in.t_ns - last_.t_ns > max_gap_ns_;
  if (a.after_gap && open_) gap_ = true;
  // A sample the saturation element had to clip is an impulse, not motion: even clipped it
  // carries up to one bound of false increment (30 m/s^2 for 5 ms is 0.15 m/s, over a hundred
  // sigmas of a 50 ms interval), so the previous sample is held in its place.
  ImuSample sample = in;
  if (saturated && have_) {
    sample = last_;
    sample.t_ns = in.t_ns;
    a.held = true;
  }
  if (recent_->full()) recent_->pop(nullptr);
  recent_->push(sample);
  if (open_ && interval_->add(sample) == Status::kFull) a.interval_full = true;
  last_ = sample;
  have_ = true;
  return a;
}

void ImuBuffer::open_interval(Preintegration* pre, std::int64_t t_ns, const Eigen::Vector3d& ba,
                              const Eigen::Vector3d& bg) {
  interval_ = pre;
  open_ = false;
  gap_ = false;
  if (!have_) return;
  gap_ = t_ns - last_.t_ns > max_gap_ns_;  // the frame came inside a hole
  ImuSample boundary = last_;
  if (boundary.t_ns < t_ns) boundary.t_ns = t_ns;
  open_ = pre->reset(boundary, ba, bg) == Status::kOk;
}

bool ImuBuffer::close_interval(std::int64_t t_ns) {
  if (!(have_ && open_ && last_.t_ns < t_ns)) return true;
  if (t_ns - last_.t_ns > max_gap_ns_) gap_ = true;
  ImuSample boundary = last_;
  boundary.t_ns = t_ns;
  return interval_->add(boundary) != Status::kFull;
}

int ImuBuffer::copy_recent(std::int64_t t0_ns, std::int64_t t1_ns) {
  int n = 0;
  for (std::size_t k = 0; k < recent_->size(); ++k) {
    const ImuSample& s = (*recent_)[k];
    if (s.t_ns < t0_ns || s.t_ns > t1_ns) continue;
    scratch_[n++] = s;
  }
  return n;
}

}  // namespace ums
