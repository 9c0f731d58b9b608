#include "core/estimator/imu_factor.hpp"

#include <algorithm>

#include "core/common/state_layout.hpp"

namespace ums {

Eigen::Vector3d ImuFactor::mean_rate_rad_s() const {
  const Preintegration* pre = residual_.preintegration();
  Eigen::Vector3d sum = Eigen::Vector3d::Zero();
  const std::size_t n = pre == nullptr ? 0 : pre->num_samples();
  for (std::size_t k = 0; k < n; ++k) sum += pre->sample(k).gyro_rad_s;
  return n == 0 ? sum : Eigen::Vector3d(sum / static_cast<double>(n));
}

bool ImuFactor::evaluate(const double* const* x, double* r, const solver::JacobianView* jac) const {
  // The speed-bias blocks as the residual reads them: with the gyro scale, both gyro biases
  // moved by s * w_mean.
  double sb_i[state::kSbSize], sb_j[state::kSbSize];
  const double* xi = x[1];
  const double* xj = x[3];
  Eigen::Vector3d w_mean = Eigen::Vector3d::Zero();
  if (gyro_scale_) {
    w_mean = mean_rate_rad_s();
    std::copy(x[1], x[1] + state::kSbSize, sb_i);
    std::copy(x[3], x[3] + state::kSbSize, sb_j);
    for (int a = 0; a < 3; ++a) {
      sb_i[state::kSbBg + a] += x[4][a] * w_mean[a];
      sb_j[state::kSbBg + a] += x[4][a] * w_mean[a];
    }
    xi = sb_i;
    xj = sb_j;
  }
  // ImuResidual writes dense row-major blocks (stride = block width); the solver hands views
  // whose stride may be wider, so go through stack copies when needed.
  ImuResidual::JacobianPose jp_i, jp_j;
  ImuResidual::JacobianSpeedBias js_i, js_j;
  const bool want = jac != nullptr;
  const bool want_s = want && gyro_scale_ && jac[4].wanted();
  const bool ok = residual_.evaluate(x[0], xi, x[2], xj, r, want && jac[0].wanted() ? jp_i.data() : nullptr,
                                     want && (jac[1].wanted() || want_s) ? js_i.data() : nullptr,
                                     want && jac[2].wanted() ? jp_j.data() : nullptr,
                                     want && (jac[3].wanted() || want_s) ? js_j.data() : nullptr);
  if (!ok || !want) return ok;
  if (jac[0].wanted()) solver::jacobian_map<15, 6>(jac[0]) = jp_i;
  if (jac[1].wanted()) solver::jacobian_map<15, 9>(jac[1]) = js_i;
  if (jac[2].wanted()) solver::jacobian_map<15, 6>(jac[2]) = jp_j;
  if (jac[3].wanted()) solver::jacobian_map<15, 9>(jac[3]) = js_j;
  if (want_s)
    solver::jacobian_map<15, 3>(jac[4]) =
        (js_i.middleCols<3>(state::kSbBg) + js_j.middleCols<3>(state::kSbBg)) * w_mean.asDiagonal();
  return true;
}

}  // namespace ums
