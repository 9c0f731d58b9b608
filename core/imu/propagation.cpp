#include "core/imu/propagation.hpp"

#include "core/imu/preintegration.hpp"
#include "core/math/so3.hpp"

namespace ums {

ImuPropagator::ImuPropagator(const Eigen::Vector3d& g_w) : g_w_(g_w) {}

void ImuPropagator::reset(const NavState& state, const ImuSample& last_sample) {
  state_ = state;
  state_.t_ns = last_sample.t_ns;
  state_.q_w_b.normalize();
  last_ = last_sample;
  initialized_ = true;
}

Status ImuPropagator::propagate(const ImuSample& sample) {
  if (!initialized_ || sample.t_ns <= last_.t_ns || !sample.gyro_rad_s.allFinite() ||
      !sample.accel_m_s2.allFinite()) {
    return Status::kInvalidInput;
  }
  const double dt = 1e-9 * static_cast<double>(sample.t_ns - last_.t_ns);
  NavState& s = state_;
  const Eigen::Vector3d a0 = s.q_w_b * (last_.accel_m_s2 - s.ba) + g_w_;
  const Eigen::Vector3d w = 0.5 * (last_.gyro_rad_s + sample.gyro_rad_s) - s.bg;
  s.q_w_b = (s.q_w_b * so3::exp_quat(w * dt)).normalized();
  const Eigen::Vector3d a1 = s.q_w_b * (sample.accel_m_s2 - s.ba) + g_w_;
  const Eigen::Vector3d a = 0.5 * (a0 + a1);
  s.p_w_b += s.v_w_b * dt + 0.5 * a * dt * dt;
  s.v_w_b += a * dt;
  s.t_ns = sample.t_ns;
  last_ = sample;
  return Status::kOk;
}

NavState predict(const NavState& state_i, const Preintegration& preintegration,
                 const Eigen::Vector3d& g_w) {
  Eigen::Vector3d alpha, beta;
  Eigen::Quaterniond gamma;
  preintegration.corrected(state_i.ba, state_i.bg, &alpha, &beta, &gamma);
  const double dt = preintegration.dt_s();
  NavState j = state_i;
  j.t_ns = preintegration.t_last_ns();
  j.p_w_b = state_i.p_w_b + state_i.v_w_b * dt + 0.5 * g_w * dt * dt + state_i.q_w_b * alpha;
  j.v_w_b = state_i.v_w_b + g_w * dt + state_i.q_w_b * beta;
  j.q_w_b = (state_i.q_w_b * gamma).normalized();
  return j;
}

}  // namespace ums
