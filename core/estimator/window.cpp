#include "core/estimator/window.hpp"

#include "core/estimator/state_blocks.hpp"

namespace ums {

Window::Window(const PreintegrationOptions& preintegration) : slots_(new WindowFrame[kSlots]) {
  for (int s = 0; s < kSlots; ++s) slots_[s].pre = Preintegration(preintegration);
}

int Window::position_of(int slot) const {
  for (int k = 0; k < n_; ++k)
    if (order_[k] == slot) return k;
  return -1;
}

int Window::slot_of_id(FrameId id) const {
  for (int k = 0; k < n_; ++k)
    if (slots_[order_[k]].id == id) return order_[k];
  return -1;
}

Eigen::Isometry3d Window::T_w_b(int slot) const { return iso_from_pose(slots_[slot].pose); }

WindowFrame& Window::push_next() {
  WindowFrame& f = slots_[next_slot_];
  f.id = next_id_++;
  order_[n_++] = next_slot_;
  return f;
}

void Window::erase(int pos) {
  for (int k = pos; k + 1 < n_; ++k) order_[k] = order_[k + 1];
  --n_;
}

void Window::choose_next_slot() {
  int free_slot = -1;
  for (int s = 0; s < kSlots && free_slot < 0; ++s)
    if (position_of(s) < 0) free_slot = s;
  next_slot_ = free_slot;
}

void Window::move(const Eigen::Matrix3d& R, const Eigen::Vector3d& from, const Eigen::Vector3d& to) {
  const Eigen::Quaterniond q(R);
  for (int k = 0; k < n_; ++k) {
    WindowFrame& f = at(k);
    state::Vec3 p = state::p(f.pose);
    p = to + R * (p - from);
    set_quat(f.pose, q * quat_of(f.pose));
    state::Vec3 v = state::v(f.sb);
    v = R * v;
  }
}

void Window::update_imu_factors(const Eigen::Vector3d& g_w) {
  for (int k = 1; k < n_; ++k) {
    WindowFrame& f = at(k);
    if (f.pre.num_samples() < 2) {
      f.imu_ok = false;
      continue;
    }
    const WindowFrame& prev = at(k - 1);
    f.pre.repropagate_if_needed(state::ba(prev.sb), state::bg(prev.sb));
    f.imu_ok = f.imu.residual().init(&f.pre, g_w) == Status::kOk;
  }
}

}  // namespace ums
