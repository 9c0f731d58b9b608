#include "hal/sim/vignetting.hpp"

#include <cmath>
#include <stdexcept>
#include <string>

namespace ums::sim {

bool VignettingOptions::validate(std::string* error) const {
  if (!(corner_gain > 0.0 && corner_gain <= 1.0) || !(axis_tilt_rad.norm() < 0.2)) {
    if (error) *error = "VignettingOptions: corner_gain in (0, 1] and |axis_tilt_rad| < 0.2 rad required";
    return false;
  }
  return true;
}

std::vector<float> make_vignetting(const std::vector<Eigen::Vector3f>& bearing_c, int width, int height,
                                   const VignettingOptions& o) {
  std::string err;
  if (!o.validate(&err)) throw std::runtime_error(err);
  if (width <= 0 || height <= 0 || bearing_c.size() != static_cast<std::size_t>(width) * height) {
    throw std::runtime_error("make_vignetting: bearing table does not match " + std::to_string(width) + "x" +
                             std::to_string(height));
  }
  const Eigen::Vector3d axis = Eigen::Vector3d(std::tan(o.axis_tilt_rad.x()), std::tan(o.axis_tilt_rad.y()), 1.0).normalized();
  auto cos_at = [&](std::size_t i) { return std::max(1e-3, bearing_c[i].cast<double>().normalized().dot(axis)); };
  const std::size_t W = static_cast<std::size_t>(width), H = static_cast<std::size_t>(height);
  const std::size_t corners[4] = {0, W - 1, (H - 1) * W, H * W - 1};
  auto corner_mean = [&](double k) {
    double s = 0.0;
    for (std::size_t c : corners) s += std::pow(cos_at(c), k);
    return s / 4.0;
  };
  // corner_mean falls monotonically in k: bisection on [0, 64].
  double k_lo = 0.0, k_hi = 64.0;
  for (int it = 0; it < 60; ++it) {
    const double k = 0.5 * (k_lo + k_hi);
    (corner_mean(k) > o.corner_gain ? k_lo : k_hi) = k;
  }
  const double k = 0.5 * (k_lo + k_hi);
  std::vector<float> gain(bearing_c.size());
  for (std::size_t i = 0; i < gain.size(); ++i) gain[i] = static_cast<float>(std::pow(cos_at(i), k));
  return gain;
}

}  // namespace ums::sim
