#include "hal/sim/lighting.hpp"

#include <catch2/catch.hpp>

#include <algorithm>

using namespace ums::sim;

namespace {
const Eigen::Vector3f kLo(-10.0f, -8.0f, -1.5f), kHi(14.0f, 12.0f, 7.0f);  // a machine-hall sized room
}

// The same surface is brighter in some places than in others (the point of uneven light), but
// within what an auto-exposed camera shows: max/min over the floor between 1.5 and 8.
TEST_CASE("lighting: irradiance varies over one surface, within a realistic range", "[sim][lighting]") {
  LightingOptions o;
  o.seed = 3;
  const Lighting l = make_lighting(kLo, kHi, o);
  REQUIRE(l.lights.size() == 5u);
  float lo = 1e9f, hi = 0.0f;
  for (float x = kLo.x() + 0.5f; x < kHi.x(); x += 1.0f)
    for (float y = kLo.y() + 0.5f; y < kHi.y(); y += 1.0f) {
      const float e = l.irradiance(Eigen::Vector3f(x, y, kLo.z()), Eigen::Vector3f::UnitZ());
      lo = std::min(lo, e);
      hi = std::max(hi, e);
    }
  INFO("floor irradiance " << lo << " .. " << hi);
  CHECK(hi / lo > 1.5f);
  CHECK(hi / lo < 8.0f);
  CHECK(lo >= l.ambient);
}

TEST_CASE("lighting: normalised to the mean irradiance, ambient share kept, one-sided", "[sim][lighting]") {
  LightingOptions o;
  o.seed = 8;
  o.mean_irradiance = 1.25f;
  o.ambient_share = 0.3f;
  const Lighting l = make_lighting(kLo, kHi, o);
  CHECK(l.ambient == Approx(0.375f));
  // Mean over a fine grid on the six faces (finer than make_lighting's own 12x12).
  double sum = 0.0;
  int n = 0;
  for (int axis = 0; axis < 3; ++axis)
    for (int side = 0; side < 2; ++side)
      for (int i = 0; i < 40; ++i)
        for (int j = 0; j < 40; ++j) {
          const int ua = (axis + 1) % 3, va = (axis + 2) % 3;
          Eigen::Vector3f x, nrm = Eigen::Vector3f::Zero();
          x[axis] = side == 0 ? kLo[axis] : kHi[axis];
          x[ua] = kLo[ua] + (kHi[ua] - kLo[ua]) * (i + 0.5f) / 40.0f;
          x[va] = kLo[va] + (kHi[va] - kLo[va]) * (j + 0.5f) / 40.0f;
          nrm[axis] = side == 0 ? 1.0f : -1.0f;
          sum += static_cast<double>(l.irradiance(x, nrm));
          ++n;
        }
  CHECK(sum / n == Approx(1.25).epsilon(0.05));
  // A surface facing away from every light gets the ambient only.
  Lighting one;
  one.ambient = 0.2f;
  one.lights.push_back({Eigen::Vector3f(0, 0, 5), 1.0f, 3.0f});
  CHECK(one.irradiance(Eigen::Vector3f(0, 0, 0), -Eigen::Vector3f::UnitZ()) == Approx(0.2f));
  // Facing it at 3 m: ambient + I * cos * r^2 / (r^2 + d^2) = 0.2 + 1 * 1 * 9 / (9 + 25) ... at d = 5.
  CHECK(one.irradiance(Eigen::Vector3f(0, 0, 0), Eigen::Vector3f::UnitZ()) == Approx(0.2f + 9.0f / 34.0f));
  // No lights: uniform light at the mean.
  o.lights = 0;
  const Lighting flat = make_lighting(kLo, kHi, o);
  CHECK(flat.irradiance(Eigen::Vector3f(1, 2, 3), Eigen::Vector3f::UnitX()) == Approx(1.25f));
}
