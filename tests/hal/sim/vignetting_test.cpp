#include "hal/sim/vignetting.hpp"

#include <catch2/catch.hpp>

#include "hal/sim/camera_rays.hpp"
#include "hal/sim/simulate.hpp"

using namespace ums::sim;

// Acceptance: the corner / centre brightness ratio is the configured one (EuRoC's lens through
// its radtan bearings), the falloff is radial and monotone, left and right differ.
TEST_CASE("vignetting: corner / centre ratio as configured, monotone along the diagonal", "[sim][vignetting]") {
  const ums::RigCalibration rig = rig_preset(CameraPreset::kEuroc);
  // As the photo style's lens (photo_renderer.hpp): left stronger, axes decentred both ways.
  const VignettingOptions options[2] = {{0.65, Eigen::Vector2d(0.012, -0.008)}, {0.70, Eigen::Vector2d(-0.010, 0.006)}};
  double corner_ratio[2] = {};
  for (int c = 0; c < 2; ++c) {
    const CameraRays rays = make_camera_rays(rig.cam[c], c);
    const std::vector<float> g = make_vignetting(rays.bearing, rays.width, rays.height, options[c]);
    const int W = rays.width, H = rays.height;
    auto at = [&](int u, int v) { return static_cast<double>(g[static_cast<std::size_t>(v) * W + u]); };
    const double centre = at(W / 2, H / 2);
    const double corners = (at(0, 0) + at(W - 1, 0) + at(0, H - 1) + at(W - 1, H - 1)) / 4.0;
    corner_ratio[c] = corners / centre;
    INFO("camera " << c << ": centre " << centre << ", corner mean " << corners);
    CHECK(centre > 0.995);
    CHECK(corner_ratio[c] == Approx(options[c].corner_gain).epsilon(0.01));
    // Monotone from the centre to each corner (along the diagonal, 20 steps).
    for (int corner = 0; corner < 4; ++corner) {
      const int cu = (corner & 1) ? W - 1 : 0, cv = (corner & 2) ? H - 1 : 0;
      double prev = 2.0;
      for (int s = 2; s <= 20; ++s) {
        const double v = at(W / 2 + (cu - W / 2) * s / 20, H / 2 + (cv - H / 2) * s / 20);
        CHECK(v <= prev + 1e-4);
        prev = v;
      }
    }
  }
  CHECK(corner_ratio[0] < corner_ratio[1] - 0.03);
  VignettingOptions bad;
  bad.corner_gain = 1.5;
  CHECK_THROWS(make_vignetting({Eigen::Vector3f::UnitZ()}, 1, 1, bad));
}
