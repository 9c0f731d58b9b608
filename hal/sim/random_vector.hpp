#pragma once
// Three random draws as a vector, in a fixed order. Eigen::Vector3d(d(), d(), d()) leaves the
// order to the compiler (function arguments are unsequenced): GCC on x86-64 drew z first, GCC on
// aarch64 and clang x first, so the same seed rendered different flights. The order here is z, y,
// x, the one the project's x86-64 datasets and pinned hashes were made with. Elsewhere in hal/sim
// the same rule: one random draw per statement (or per declarator), in that historical order.

#include <Eigen/Core>

namespace ums::sim {

template <class Draw>
Eigen::Vector3d draw_vector3(Draw&& draw) {
  const double z = draw();
  const double y = draw();
  const double x = draw();
  return Eigen::Vector3d(x, y, z);
}

}  // namespace ums::sim
