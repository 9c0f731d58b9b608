#include "hal/d455/imu_fuser.hpp"

namespace ums::d455 {

void ImuFuser::push_accel(const ImuAxisSample& a) {
  if (!accel_.empty() && a.t_ns <= accel_.back().t_ns) {
    ++stats_.accel_out_of_order;
    return;
  }
  if (accel_.full()) accel_.pop(nullptr);  // history only: the oldest is no longer needed
  accel_.push(a);
  drain();
}

void ImuFuser::push_gyro(const ImuAxisSample& g) {
  if (!gyro_.empty() && g.t_ns <= gyro_.back().t_ns) {
    ++stats_.gyro_out_of_order;
    return;
  }
  if (g.t_ns <= last_emitted_ns_) {
    ++stats_.gyro_out_of_order;
    return;
  }
  if (gyro_.full()) {
    gyro_.pop(nullptr);
    ++stats_.gyro_overflow;
  }
  gyro_.push(g);
  drain();
}

void ImuFuser::drain() {
  while (!gyro_.empty() && !accel_.empty()) {
    const ImuAxisSample& g = gyro_.front();
    if (g.t_ns > accel_.back().t_ns) return;  // wait for a later accel
    if (g.t_ns < accel_.front().t_ns) {
      ++stats_.gyro_unbracketed;
      gyro_.pop(nullptr);
      continue;
    }
    // Bracket: accel_[i-1].t < g.t <= accel_[i].t (or equal to the first).
    std::size_t i = 0;
    while (accel_[i].t_ns < g.t_ns) ++i;
    ImuSample s;
    s.t_ns = g.t_ns;
    s.gyro_rad_s = g.v;
    if (accel_[i].t_ns == g.t_ns || i == 0) {
      s.accel_m_s2 = accel_[i].v;
    } else {
      const ImuAxisSample& a0 = accel_[i - 1];
      const ImuAxisSample& a1 = accel_[i];
      const double w = static_cast<double>(g.t_ns - a0.t_ns) / static_cast<double>(a1.t_ns - a0.t_ns);
      s.accel_m_s2 = (1.0 - w) * a0.v + w * a1.v;
    }
    gyro_.pop(nullptr);
    if (out_.push(s) != Status::kOk) {
      ++stats_.output_overflow;
      continue;
    }
    last_emitted_ns_ = s.t_ns;
    ++stats_.emitted;
  }
}

}  // namespace ums::d455
