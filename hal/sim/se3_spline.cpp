#include "hal/sim/se3_spline.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

#include "core/math/se3.hpp"

namespace ums::sim {

void Se3Spline::init(std::int64_t t0_ns, double dt_s, std::vector<Eigen::Isometry3d> T_w_b) {
  if (T_w_b.size() < 4 || !(dt_s > 0.0)) {
    throw std::runtime_error("Se3Spline: needs >= 4 control poses and dt > 0, got " + std::to_string(T_w_b.size()));
  }
  t0_ns_ = t0_ns;
  dt_s_ = dt_s;
  T_ = std::move(T_w_b);
  xi_.assign(T_.size(), Eigen::Matrix<double, 6, 1>::Zero());
  for (std::size_t k = 1; k < T_.size(); ++k) xi_[k] = se3::log(se3::inverse(T_[k - 1]) * T_[k]);
}

std::int64_t Se3Spline::start_ns() const { return t0_ns_ + static_cast<std::int64_t>(std::llround(dt_s_ * 1e9)); }

std::int64_t Se3Spline::end_ns() const {
  return t0_ns_ + static_cast<std::int64_t>(std::llround(dt_s_ * 1e9 * static_cast<double>(T_.size() - 2)));
}

Eigen::Isometry3d Se3Spline::evaluate(std::int64_t t_ns) const {
  t_ns = std::clamp(t_ns, start_ns(), end_ns());
  const double s = static_cast<double>(t_ns - t0_ns_) * 1e-9 / dt_s_;
  const int i = std::clamp(static_cast<int>(std::floor(s)), 1, static_cast<int>(T_.size()) - 3);
  const double u = s - i;
  const double u2 = u * u, u3 = u2 * u;
  const double Bc[3] = {(5.0 + 3.0 * u - 3.0 * u2 + u3) / 6.0, (1.0 + 3.0 * u + 3.0 * u2 - 2.0 * u3) / 6.0,
                        u3 / 6.0};
  Eigen::Isometry3d T = T_[static_cast<std::size_t>(i - 1)];
  for (int j = 0; j < 3; ++j) {
    T = se3::compose(T, se3::exp(Bc[j] * xi_[static_cast<std::size_t>(i + j)]));
  }
  return T;
}

}  // namespace ums::sim
