#include "hal/replay/euroc_sensor_yaml.hpp"

#include <catch2/catch.hpp>
#include <fstream>

#include "tests/common/test_paths.hpp"

TEST_CASE("EuRoC sensor.yaml of the real micro sequence", "[euroc][yaml][real]") {
  const std::string mav0 = ums::test::euroc_micro_dir() + "/mav0";
  const ums::CameraCalibration cam1 = ums::hal::read_euroc_camera_yaml(mav0 + "/cam1/sensor.yaml");
  CHECK(cam1.fx == 457.587);
  CHECK(cam1.distortion[0] == -0.28368365);
  CHECK(cam1.T_b_c.translation().x() == -0.0198435579556);
  // The printed rotation is orthonormal to ~1e-7; re-orthonormalizing moves entries by less.
  CHECK(cam1.T_b_c.linear()(0, 0) == Approx(0.0125552670891).margin(1e-6));
  CHECK((cam1.T_b_c.linear().transpose() * cam1.T_b_c.linear() - Eigen::Matrix3d::Identity()).norm() < 1e-12);
  const ums::ImuCalibration imu = ums::hal::read_euroc_imu_yaml(mav0 + "/imu0/sensor.yaml");
  CHECK(imu.accel_random_walk == 3.0e-3);
  CHECK_THROWS_WITH(ums::hal::read_euroc_imu_yaml(mav0 + "/cam0/sensor.yaml"),
                    Catch::Contains("cam0/sensor.yaml: key 'sensor_type': expected 'imu', got 'camera'"));
}

TEST_CASE("EuRoC camera sensor.yaml: each invalid value names its key", "[euroc][yaml]") {
  const std::string dir = ums::test::make_temp_dir("sensor_yaml_invalid");
  const std::string good =
      "sensor_type: camera\nT_BS:\n  cols: 4\n  rows: 4\n  data: [1,0,0,0, 0,1,0,0, 0,0,1,0, 0,0,0,1]\n"
      "rate_hz: 20\nresolution: [752, 480]\ncamera_model: pinhole\nintrinsics: [458.6, 457.3, 367.2, 248.4]\n"
      "distortion_model: radial-tangential\ndistortion_coefficients: [-0.28, 0.07, 0.0002, 0.00002]\n";
  const std::string path = dir + "/sensor.yaml";
  std::ofstream(path) << good;
  CHECK(ums::hal::read_euroc_camera_yaml(path).width == 752);

  struct Case {
    const char* from;
    const char* to;
    const char* message;
  };
  const Case cases[] = {
      {"rate_hz: 20", "rate_hz: -20", "key 'rate_hz': must be > 0, got -20"},
      {"[752, 480]", "[752.5, 480]", "key 'resolution': got [752.5, 480]"},
      {"camera_model: pinhole", "camera_model: omni", "key 'camera_model': only 'pinhole'"},
      {"[458.6, 457.3, 367.2, 248.4]", "[0, 457.3, 367.2, 248.4]", "key 'intrinsics': fu and fv must be > 0"},
      {"[458.6, 457.3, 367.2, 248.4]", "[458.6, 457.3, 367.2]", "key 'intrinsics': expected a list of 4 numbers"},
      {"radial-tangential", "fov", "key 'distortion_model': expected 'radial-tangential' or 'equidistant', got 'fov'"},
      {"[-0.28, 0.07, 0.0002, 0.00002]", "[-0.28, 0.07, 0.0002, 0.00002, 0.1]",
       "key 'distortion_coefficients': expected a list of 4 numbers"},
      {"0,0,0,1]", "0,0,1,1]", "key 'T_BS': last row must be [0, 0, 0, 1]"},
      {"rows: 4", "rows: 3", "key 'T_BS': expected a 4x4 matrix"},
  };
  for (const Case& c : cases) {
    std::string text = good;
    text.replace(text.find(c.from), std::strlen(c.from), c.to);
    std::ofstream(path) << text;
    CAPTURE(c.to);
    CHECK_THROWS_WITH(ums::hal::read_euroc_camera_yaml(path), Catch::Contains("sensor.yaml: ") && Catch::Contains(c.message));
  }
}
