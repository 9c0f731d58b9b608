#include "core/camera/camera.hpp"

#include <cmath>

#include <catch2/catch.hpp>

namespace {

// EuRoC V1_01 cam0, numbers from ../shared/data/euroc/V1_01_easy_micro/mav0/cam0/sensor.yaml.
ums::CameraD euroc_cam0() {
  return ums::CameraD(ums::CameraModel::kPinholeRadTan, 752, 480, 458.654, 457.296, 367.215, 248.375,
                      {-0.28340811, 0.07395907, 0.00019359, 1.76187114e-05});
}

// A fisheye-like equidistant camera (coefficients of the order Kalibr reports for a T265).
ums::CameraD equidistant_cam() {
  // Rays beyond 78 degrees are skipped by the round-trip check; the corners of this image are
  // beyond 90 degrees (unproject still returns their bearing, with z < 0).
  return ums::CameraD(ums::CameraModel::kPinholeEquidistant, 848, 800, 285.7, 285.9, 418.9, 403.3,
                      {-0.0062, 0.0431, -0.0404, 0.0077});
}

template <typename Cam>
void check_round_trip_and_jacobian(const Cam& cam, double max_roundtrip_px) {
  double worst_px = 0.0, worst_jac = 0.0;
  int n = 0;
  for (int v = 10; v < cam.height() - 10; v += 37) {
    for (int u = 10; u < cam.width() - 10; u += 41) {
      const Eigen::Vector2d uv(u + 0.25, v + 0.75);
      Eigen::Vector3d b;
      REQUIRE(cam.unproject(uv, &b));
      REQUIRE(std::abs(b.norm() - 1.0) < 1e-12);
      if (b.z() < 0.2) continue;  // beyond ~78 degrees: outside what project() serves
      const Eigen::Vector3d p = 2.7 * b;  // any depth on the ray
      Eigen::Vector2d uv2;
      Eigen::Matrix<double, 2, 3> J;
      REQUIRE(cam.project(p, &uv2, &J));
      worst_px = std::max(worst_px, (uv2 - uv).norm());
      // Central differences of project() against the analytic d_uv_d_p.
      const double h = 1e-6;
      for (int k = 0; k < 3; ++k) {
        Eigen::Vector3d dp = Eigen::Vector3d::Zero();
        dp(k) = h;
        Eigen::Vector2d a, c;
        cam.project(p + dp, &a);
        cam.project(p - dp, &c);
        const Eigen::Vector2d num = (a - c) / (2 * h);
        worst_jac = std::max(worst_jac, (num - J.col(k)).norm() / std::max(1.0, J.col(k).norm()));
      }
      ++n;
    }
  }
  INFO("points " << n << " worst round trip px " << worst_px << " worst jacobian rel " << worst_jac);
  CHECK(n > 100);
  CHECK(worst_px < max_roundtrip_px);
  CHECK(worst_jac < 1e-6);
}

}  // namespace

TEST_CASE("radtan (EuRoC cam0): unproject then project returns the pixel and d_uv_d_p matches differences") {
  check_round_trip_and_jacobian(euroc_cam0(), 1e-6);
}

TEST_CASE("equidistant: unproject then project returns the pixel and d_uv_d_p matches differences") {
  check_round_trip_and_jacobian(equidistant_cam(), 1e-6);
}

TEST_CASE("float camera undistorts EuRoC pixels to within 1e-3 px of the double one") {
  const ums::CameraD cd = euroc_cam0();
  const ums::Camera cf(ums::CameraModel::kPinholeRadTan, 752, 480, 458.654f, 457.296f, 367.215f, 248.375f,
                       {-0.28340811f, 0.07395907f, 0.00019359f, 1.76187114e-05f});
  double worst = 0.0;
  for (int v = 0; v < 480; v += 20) {
    for (int u = 0; u < 752; u += 20) {
      Eigen::Vector2d xyd;
      Eigen::Vector2f xyf;
      REQUIRE(cd.undistort_point(Eigen::Vector2d(u, v), &xyd));
      REQUIRE(cf.undistort_point(Eigen::Vector2f(static_cast<float>(u), static_cast<float>(v)), &xyf));
      worst = std::max(worst, (xyf.cast<double>() - xyd).norm() * cd.fx());
    }
  }
  INFO("worst float-vs-double difference px " << worst);
  CHECK(worst < 1e-3);
}

TEST_CASE("radtan distortion at the EuRoC image corner is large (the test is not trivial)") {
  // The corner pixel (0, 0) undistorts ~40 px away from its pinhole position, so the
  // round-trip test above exercises the iteration, not an identity.
  const ums::CameraD cam = euroc_cam0();
  Eigen::Vector2d xy;
  REQUIRE(cam.undistort_point(Eigen::Vector2d(0, 0), &xy));
  const Eigen::Vector2d pinhole(cam.fx() * xy.x() + cam.cx(), cam.fy() * xy.y() + cam.cy());
  INFO("corner moves by " << pinhole.norm() << " px");
  CHECK(pinhole.norm() > 30.0);
}

TEST_CASE("project rejects points behind the camera") {
  const ums::CameraD cam = euroc_cam0();
  Eigen::Vector2d uv;
  CHECK_FALSE(cam.project(Eigen::Vector3d(0.1, 0.2, -1.0), &uv));
  CHECK(cam.project(Eigen::Vector3d(0.1, 0.2, 1.0), &uv));
}

TEST_CASE("distort Jacobian matches central differences for both models") {
  for (const ums::CameraD& cam : {euroc_cam0(), equidistant_cam()}) {
    for (const Eigen::Vector2d& xy : {Eigen::Vector2d(0.3, -0.2), Eigen::Vector2d(-0.6, 0.45), Eigen::Vector2d(0.01, 0.02)}) {
      Eigen::Matrix2d J;
      cam.distort(xy, &J);
      const double h = 1e-7;
      for (int k = 0; k < 2; ++k) {
        Eigen::Vector2d d = Eigen::Vector2d::Zero();
        d(k) = h;
        const Eigen::Vector2d num = (cam.distort(xy + d) - cam.distort(xy - d)) / (2 * h);
        CHECK((num - J.col(k)).norm() < 1e-6);
      }
    }
  }
}
