#include "core/estimator/imu_factor.hpp"

namespace ums {

bool ImuFactor::evaluate(const double* const* x, double* r, const solver::JacobianView* jac) const {
  // ImuResidual writes dense row-major blocks (stride = block width); the solver hands views
  // whose stride may be wider, so go through stack copies when needed.
  ImuResidual::JacobianPose jp_i, jp_j;
  ImuResidual::JacobianSpeedBias js_i, js_j;
  const bool want = jac != nullptr;
  const bool ok = residual_.evaluate(x[0], x[1], x[2], x[3], r,
                                     want && jac[0].wanted() ? jp_i.data() : nullptr,
                                     want && jac[1].wanted() ? js_i.data() : nullptr,
                                     want && jac[2].wanted() ? jp_j.data() : nullptr,
                                     want && jac[3].wanted() ? js_j.data() : nullptr);
  if (!ok || !want) return ok;
  if (jac[0].wanted()) solver::jacobian_map<15, 6>(jac[0]) = jp_i;
  if (jac[1].wanted()) solver::jacobian_map<15, 9>(jac[1]) = js_i;
  if (jac[2].wanted()) solver::jacobian_map<15, 6>(jac[2]) = jp_j;
  if (jac[3].wanted()) solver::jacobian_map<15, 9>(jac[3]) = js_j;
  return true;
}

}  // namespace ums
