#include "hal/sim/lighting.hpp"

#include <algorithm>
#include <cmath>

namespace ums::sim {
namespace {

float uniform(std::uint64_t& s, float a, float b) {
  std::uint64_t z = (s += 0x9E3779B97F4A7C15ULL);
  z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ULL;
  z = (z ^ (z >> 27)) * 0x94D049BB133111EBULL;
  z ^= z >> 31;
  return a + (b - a) * static_cast<float>(static_cast<double>(z >> 11) * (1.0 / 9007199254740992.0));
}

// Mean of the light sum (without ambient) over a grid of points on the six faces of the room.
float mean_direct(const Lighting& l, const Eigen::Vector3f& lo, const Eigen::Vector3f& hi) {
  constexpr int kGrid = 12;
  double sum = 0.0;
  int n = 0;
  for (int axis = 0; axis < 3; ++axis) {
    for (int side = 0; side < 2; ++side) {
      const int ua = (axis + 1) % 3, va = (axis + 2) % 3;
      Eigen::Vector3f normal = Eigen::Vector3f::Zero();
      normal[axis] = side == 0 ? 1.0f : -1.0f;
      for (int i = 0; i < kGrid; ++i) {
        for (int j = 0; j < kGrid; ++j) {
          Eigen::Vector3f x;
          x[axis] = side == 0 ? lo[axis] : hi[axis];
          x[ua] = lo[ua] + (hi[ua] - lo[ua]) * (static_cast<float>(i) + 0.5f) / kGrid;
          x[va] = lo[va] + (hi[va] - lo[va]) * (static_cast<float>(j) + 0.5f) / kGrid;
          sum += static_cast<double>(l.irradiance(x, normal) - l.ambient);
          ++n;
        }
      }
    }
  }
  return static_cast<float>(sum / n);
}

}  // namespace

float Lighting::irradiance(const Eigen::Vector3f& x_w, const Eigen::Vector3f& n_w) const {
  float e = ambient;
  for (const PointLight& l : lights) {
    const Eigen::Vector3f d = l.p_w - x_w;
    const float d2 = std::max(d.squaredNorm(), 1e-6f);
    const float n_dot_d = n_w.dot(d);
    // cos = n.d / |d|, falloff = r^2 / (r^2 + d^2): one sqrt and one division per light (hot loop).
    const float r2 = l.radius_m * l.radius_m;
    if (n_dot_d > 0.0f) e += l.intensity * n_dot_d * r2 / (std::sqrt(d2) * (r2 + d2));
  }
  return e;
}

Lighting make_lighting(const Eigen::Vector3f& lo, const Eigen::Vector3f& hi, const LightingOptions& o) {
  Lighting l;
  std::uint64_t s = 0x11A7ULL + 7919ULL * o.seed;
  for (int k = 0; k < o.lights; ++k) {
    PointLight p;
    // Two in three hang 0.3-1 m under the ceiling; the others sit low on a wall.
    const bool ceiling = k % 3 != 2;
    p.p_w.x() = uniform(s, lo.x() + 0.5f, hi.x() - 0.5f);
    p.p_w.y() = uniform(s, lo.y() + 0.5f, hi.y() - 0.5f);
    p.p_w.z() = ceiling ? hi.z() - uniform(s, 0.3f, 1.0f) : lo.z() + uniform(s, 0.5f, 2.0f);
    if (!ceiling) {
      const int axis = uniform(s, 0.0f, 1.0f) < 0.5f ? 0 : 1;
      p.p_w[axis] = uniform(s, 0.0f, 1.0f) < 0.5f ? lo[axis] + 0.3f : hi[axis] - 0.3f;
    }
    p.intensity = uniform(s, 0.5f, 1.5f);
    // Falloff radius scaled with the room: a light brightens a region of the room, not a spot
    // that the normalisation would have to blow up to reach the mean.
    p.radius_m = uniform(s, 0.2f, 0.45f) * std::max(hi.x() - lo.x(), hi.y() - lo.y());
    l.lights.push_back(p);
  }
  l.ambient = 0.0f;
  const float direct = l.lights.empty() ? 0.0f : mean_direct(l, lo, hi);
  const float want_direct = (1.0f - o.ambient_share) * o.mean_irradiance;
  const float scale = direct > 0.0f ? want_direct / direct : 0.0f;
  for (PointLight& p : l.lights) p.intensity *= scale;
  l.ambient = l.lights.empty() ? o.mean_irradiance : o.ambient_share * o.mean_irradiance;
  return l;
}

}  // namespace ums::sim
