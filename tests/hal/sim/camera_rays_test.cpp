#include "hal/sim/camera_rays.hpp"

#include <catch2/catch.hpp>

#include <cmath>

#include "core/camera/camera.hpp"
#include "hal/sim/simulate.hpp"

using namespace ums::sim;

// Every ray projects back onto its pixel through the camera model (EuRoC radtan), so whatever a
// renderer draws along it lands where core/camera expects; the footprint is 1/f at the centre.
TEST_CASE("camera rays: unit bearings that project back onto their pixels", "[sim][camera_rays]") {
  const ums::RigCalibration rig = rig_preset(CameraPreset::kEuroc);
  for (int c = 0; c < 2; ++c) {
    const CameraRays rays = make_camera_rays(rig.cam[c], c);
    REQUIRE(rays.bearing.size() == 752u * 480u);
    const auto cam = ums::CameraT<double>::from_calibration(rig.cam[c]);
    double worst_px = 0.0;
    for (int v = 0; v < 480; v += 7)
      for (int u = 0; u < 752; u += 7) {
        const Eigen::Vector3f& b = rays.bearing[static_cast<std::size_t>(v) * 752 + u];
        CHECK(std::abs(b.norm() - 1.0f) < 1e-5f);
        Eigen::Vector2d uv;
        REQUIRE(cam.project(b.cast<double>(), &uv));
        worst_px = std::max(worst_px, (uv - Eigen::Vector2d(u, v)).norm());
      }
    CHECK(worst_px < 2e-3);  // float bearings
    const float centre = rays.footprint[static_cast<std::size_t>(248) * 752 + 367];
    CHECK(centre == Approx(1.0 / rig.cam[c].fx).epsilon(0.01));
  }
  ums::CameraCalibration bad = rig.cam[0];
  bad.fx = 0.0;
  CHECK_THROWS(make_camera_rays(bad, 0));
}
