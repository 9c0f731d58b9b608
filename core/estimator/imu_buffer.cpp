#include "core/estimator/imu_buffer.hpp"

#include <algorithm>

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
  if (a.after_gap) note_hole(last_.t_ns, in.t_ns);
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
  if (open_ && add_bridged(sample) == Status::kFull) a.interval_full = true;
  last_ = sample;
  have_ = true;
  return a;
}

void ImuBuffer::open_interval(Preintegration* pre, std::int64_t t_ns, const Eigen::Vector3d& ba,
                              const Eigen::Vector3d& bg) {
  interval_ = pre;
  open_ = false;
  gap_ = false;
  interval_t0_ns_ = t_ns;
  hole_ns_ = 0;
  if (!have_) return;
  gap_ = t_ns - last_.t_ns > max_gap_ns_;  // the frame came inside a hole
  if (gap_) hole_start_ns_ = hole_end_ns_ = last_.t_ns;
  ImuSample boundary = last_;
  if (boundary.t_ns < t_ns) boundary.t_ns = t_ns;
  open_ = pre->reset(boundary, ba, bg) == Status::kOk;
}

bool ImuBuffer::close_interval(std::int64_t t_ns) {
  if (!(have_ && open_ && last_.t_ns < t_ns)) return true;
  if (t_ns - last_.t_ns > max_gap_ns_) note_hole(last_.t_ns, t_ns);
  ImuSample boundary = last_;
  boundary.t_ns = t_ns;
  return add_bridged(boundary) != Status::kFull;
}

// An interval of one step (a frame inside a hole, the held sample to the next) gets its alpha
// and beta noise from the same inputs: a covariance of rank 3 in their 6 dimensions, no factor at
// all. A sample halfway (interpolated) makes two steps and a full-rank covariance.
Status ImuBuffer::add_bridged(const ImuSample& next) {
  if (gap_ && interval_->num_samples() == 1) {
    const ImuSample& first = interval_->sample(0);
    const Status s = interval_->add(interpolate_imu(first, next, first.t_ns + (next.t_ns - first.t_ns) / 2));
    if (s == Status::kFull) return s;
  }
  return interval_->add(next);
}

void ImuBuffer::note_hole(std::int64_t last_sample_ns, std::int64_t end_ns) {
  hole_start_ns_ = last_sample_ns;
  hole_end_ns_ = end_ns;
  if (!open_) return;
  gap_ = true;
  hole_ns_ += end_ns - std::max(last_sample_ns, interval_t0_ns_);
}

void ImuBuffer::note_lost_time(std::int64_t lost_ns) {
  if (!have_ || lost_ns <= 0) return;
  hole_start_ns_ = last_.t_ns;
  hole_end_ns_ = last_.t_ns + lost_ns;
  if (!open_) return;
  gap_ = true;
  hole_ns_ += lost_ns;
}

bool ImuBuffer::motion_density_before_hole(double* q_gyro, double* q_accel) const {
  constexpr std::int64_t kSpanNs = 1000000000;  // the second before the hole
  double sum_w = 0.0, sum_a = 0.0;
  int n = 0;
  for (std::size_t k = 1; k < recent_->size(); ++k) {
    const ImuSample& s0 = (*recent_)[k - 1];
    const ImuSample& s1 = (*recent_)[k];
    if (s1.t_ns > hole_start_ns_ || s0.t_ns < hole_start_ns_ - kSpanNs) continue;
    const std::int64_t dt_ns = s1.t_ns - s0.t_ns;
    if (dt_ns <= 0 || dt_ns > max_gap_ns_) continue;
    const double dt_s = 1e-9 * static_cast<double>(dt_ns);
    sum_w += (s1.gyro_rad_s - s0.gyro_rad_s).squaredNorm() / (3.0 * dt_s);
    sum_a += (s1.accel_m_s2 - s0.accel_m_s2).squaredNorm() / (3.0 * dt_s);
    ++n;
  }
  if (n == 0) return false;
  *q_gyro = sum_w / n;
  *q_accel = sum_a / n;
  return true;
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
