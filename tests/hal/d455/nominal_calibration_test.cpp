#include "hal/d455/nominal_calibration.hpp"

#include <catch2/catch.hpp>

#include <cmath>
#include <string>

#include "hal/replay/yaml_file.hpp"

using namespace ums::d455;

TEST_CASE("Nominal D455 calibration: 95 mm baseline along x, CAD lever arm, rectified pinhole, ~89 deg HFOV", "[d455][calib]") {
  const ums::RigCalibration rig = d455_nominal_calibration(848, 480, 30.0, 400.0);
  const Eigen::Vector3d baseline = rig.cam[1].T_b_c.translation() - rig.cam[0].T_b_c.translation();
  CHECK(baseline.x() == Approx(0.095));
  CHECK(baseline.tail<2>().norm() == 0.0);
  CHECK(rig.cam[0].T_b_c.translation().x() == Approx(-0.03022));
  CHECK(rig.cam[0].T_b_c.linear().isIdentity());
  CHECK(rig.cam[0].fx == rig.cam[1].fx);
  CHECK(rig.cam[0].distortion[0] == 0.0);
  // Horizontal field of view from the nominal focal length: spec says ~87 deg, notes ~89.3 deg.
  const double hfov_deg = 2.0 * std::atan(848.0 / 2.0 / rig.cam[0].fx) * 180.0 / M_PI;
  CHECK(hfov_deg == Approx(89.3).margin(0.2));
  CHECK(rig.imu.rate_hz == 400.0);
  const ums::RigCalibration vga = d455_nominal_calibration(640, 480, 15.0, 200.0);
  CHECK(vga.cam[0].fx == Approx(388.780));
  CHECK_THROWS_AS(d455_nominal_calibration(1280, 720, 30.0, 200.0), std::invalid_argument);
}

TEST_CASE("board/d455/d455.yaml states the same nominal calibration as the code", "[d455][calib]") {
  const ums::RigCalibration rig = d455_nominal_calibration(848, 480, 30.0, 400.0);
  const std::string dir = std::string(UMS_SOURCE_DIR) + "/board/d455";
  const ums::hal::YamlFile config(dir + "/d455.yaml");
  CHECK(config.integer("num_of_cam") == 2);
  CHECK(config.integer("image_width") == 848);
  for (int side = 0; side < 2; ++side) {
    const Eigen::Isometry3d T = config.transform(side == 0 ? "body_T_cam0" : "body_T_cam1");
    CHECK((T.matrix() - rig.cam[side].T_b_c.matrix()).norm() < 1e-12);
    const ums::hal::YamlFile cam(dir + "/" + config.text(side == 0 ? "cam0_calib" : "cam1_calib"));
    CHECK(cam.text("model_type") == "PINHOLE");
    CHECK(cam.number("projection_parameters.fx") == rig.cam[side].fx);
    CHECK(cam.number("projection_parameters.cx") == rig.cam[side].cx);
    CHECK(cam.number("projection_parameters.cy") == rig.cam[side].cy);
    CHECK(cam.number("distortion_parameters.k1") == 0.0);
  }
  CHECK(config.number("acc_n") == rig.imu.accel_noise_density);
  CHECK(config.number("gyr_n") == rig.imu.gyro_noise_density);
  CHECK(config.number("acc_w") == Approx(rig.imu.accel_random_walk).epsilon(1e-12));
  CHECK(config.number("gyr_w") == Approx(rig.imu.gyro_random_walk).epsilon(1e-12));
}
