#include "hal/sim/spline.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>

#include "core/math/so3.hpp"

namespace ums::sim {

void PoseSpline::init(std::int64_t t0_ns, double dt_s, std::vector<Eigen::Quaterniond> q_w_b,
                      std::vector<Eigen::Vector3d> p_w_b) {
  if (q_w_b.size() < 4 || q_w_b.size() != p_w_b.size() || !(dt_s > 0.0)) {
    throw std::runtime_error("PoseSpline: needs >= 4 control points and dt > 0, got " +
                             std::to_string(q_w_b.size()));
  }
  t0_ns_ = t0_ns;
  dt_s_ = dt_s;
  q_ = std::move(q_w_b);
  p_ = std::move(p_w_b);
  d_.assign(q_.size(), Eigen::Vector3d::Zero());
  for (std::size_t k = 1; k < q_.size(); ++k) d_[k] = so3::log(q_[k - 1].conjugate() * q_[k]);
}

std::int64_t PoseSpline::start_ns() const { return t0_ns_ + static_cast<std::int64_t>(std::llround(dt_s_ * 1e9)); }
std::int64_t PoseSpline::end_ns() const {
  return t0_ns_ + static_cast<std::int64_t>(std::llround(dt_s_ * 1e9 * static_cast<double>(p_.size() - 2)));
}

SplineState PoseSpline::evaluate(std::int64_t t_ns) const {
  t_ns = std::clamp(t_ns, start_ns(), end_ns());
  const double s = static_cast<double>(t_ns - t0_ns_) * 1e-9 / dt_s_;
  int i = static_cast<int>(std::floor(s));
  i = std::clamp(i, 1, static_cast<int>(p_.size()) - 3);
  const double u = s - i;
  const double u2 = u * u, u3 = u2 * u;
  const double B[4] = {1.0, (5.0 + 3.0 * u - 3.0 * u2 + u3) / 6.0, (1.0 + 3.0 * u + 3.0 * u2 - 2.0 * u3) / 6.0,
                       u3 / 6.0};
  const double inv_dt = 1.0 / dt_s_;
  const double dB[4] = {0.0, (3.0 - 6.0 * u + 3.0 * u2) / 6.0 * inv_dt, (3.0 + 6.0 * u - 6.0 * u2) / 6.0 * inv_dt,
                        3.0 * u2 / 6.0 * inv_dt};
  const double ddB[4] = {0.0, (-6.0 + 6.0 * u) / 6.0 * inv_dt * inv_dt, (6.0 - 12.0 * u) / 6.0 * inv_dt * inv_dt,
                         u * inv_dt * inv_dt};
  SplineState st;
  st.p_w_b = p_[i - 1];
  Eigen::Quaterniond q = q_[i - 1];
  Eigen::Vector3d w = Eigen::Vector3d::Zero();
  for (int j = 1; j <= 3; ++j) {
    const int k = i - 1 + j;
    const Eigen::Vector3d dp = p_[k] - p_[k - 1];
    st.p_w_b += B[j] * dp;
    st.v_w_b += dB[j] * dp;
    st.a_w_b += ddB[j] * dp;
    const Eigen::Quaterniond A = so3::exp_quat(B[j] * d_[k]);
    q = q * A;
    w = A.conjugate() * w + dB[j] * d_[k];
  }
  st.q_w_b = q.normalized();
  st.omega_b_rad_s = w;
  return st;
}

}  // namespace ums::sim
