#include "hal/d455/kalibr_reader.hpp"

#include <catch2/catch.hpp>

#include <cmath>
#include <fstream>
#include <sstream>

#include "tests/common/test_paths.hpp"

using namespace ums::d455;

namespace {
// A stereo-IMU chain shaped like a D455 Kalibr result on rectified 640x360 IR (values of the
// order of notes §5.4), with cam0 rotated 1 degree about y against the IMU to test the inverse.
void write_chain(const std::string& path) {
  const double a = M_PI / 180.0, c = std::cos(a), s = std::sin(a);
  std::ofstream f(path);
  f.precision(17);
  f << "cam0:\n  T_cam_imu:\n"
    << "  - [" << c << ", 0.0, " << s << ", 0.0173]\n"
    << "  - [0.0, 1.0, 0.0, -0.0085]\n"
    << "  - [" << -s << ", 0.0, " << c << ", -0.0187]\n"
    << "  - [0.0, 0.0, 0.0, 1.0]\n"
    << "  cam_overlaps: [1]\n  camera_model: pinhole\n  distortion_coeffs: [0.001, -0.002, 0.0001, 0.0002]\n"
    << "  distortion_model: radtan\n  intrinsics: [320.17, 320.03, 314.07, 180.37]\n  resolution: [640, 360]\n"
    << "  rostopic: /camera/infra1/image_rect_raw\n  timeshift_cam_imu: 0.0048\n"
    << "cam1:\n  T_cn_cnm1:\n  - [1.0, 0.0, 0.0, -0.09397]\n  - [0.0, 1.0, 0.0, 0.0]\n  - [0.0, 0.0, 1.0, 0.0]\n"
    << "  - [0.0, 0.0, 0.0, 1.0]\n  T_cam_imu:\n"
    << "  - [" << c << ", 0.0, " << s << ", " << 0.0173 - 0.09397 << "]\n"
    << "  - [0.0, 1.0, 0.0, -0.0085]\n"
    << "  - [" << -s << ", 0.0, " << c << ", -0.0187]\n"
    << "  - [0.0, 0.0, 0.0, 1.0]\n"
    << "  cam_overlaps: [0]\n  camera_model: pinhole\n  distortion_coeffs: [0.0, 0.0, 0.0, 0.0]\n"
    << "  distortion_model: equidistant\n  intrinsics: [320.5, 320.4, 313.9, 180.1]\n  resolution: [640, 360]\n"
    << "  rostopic: /camera/infra2/image_rect_raw\n  timeshift_cam_imu: 0.0049\n";
}
}  // namespace

TEST_CASE("Kalibr camchain-imucam and imu files give T_b_c = T_cam_imu^-1, td and noise", "[d455][kalibr]") {
  const std::string dir = ums::test::make_temp_dir("d455_kalibr");
  write_chain(dir + "/camchain-imucam.yaml");
  std::ofstream(dir + "/imu.yaml") << "imu0:\n  T_i_b:\n  - [1.0, 0.0, 0.0, 0.0]\n  - [0.0, 1.0, 0.0, 0.0]\n"
                                      "  - [0.0, 0.0, 1.0, 0.0]\n  - [0.0, 0.0, 0.0, 1.0]\n"
                                      "  accelerometer_noise_density: 0.00208\n  accelerometer_random_walk: 0.000413\n"
                                      "  gyroscope_noise_density: 0.000206\n  gyroscope_random_walk: 1.11e-05\n"
                                      "  model: calibrated\n  rostopic: /imu\n  time_offset: 0.0\n  update_rate: 400.0\n";
  const ums::RigCalibration rig = read_kalibr(dir + "/camchain-imucam.yaml", dir + "/imu.yaml");
  CHECK(rig.cam[0].fx == 320.17);
  CHECK(rig.cam[0].cy == 180.37);
  CHECK(rig.cam[0].width == 640);
  CHECK(rig.cam[0].height == 360);
  CHECK(rig.cam[0].model == ums::CameraModel::kPinholeRadTan);
  CHECK(rig.cam[1].model == ums::CameraModel::kPinholeEquidistant);
  CHECK(rig.cam[0].distortion[1] == -0.002);
  // A point fixed in the IMU frame maps to the same body point through both routes.
  const Eigen::Vector3d p_i(0.3, -0.2, 1.5);
  Eigen::Matrix3d R;
  const double a = M_PI / 180.0;
  R << std::cos(a), 0, std::sin(a), 0, 1, 0, -std::sin(a), 0, std::cos(a);
  const Eigen::Vector3d p_c0 = R * p_i + Eigen::Vector3d(0.0173, -0.0085, -0.0187);
  CHECK((rig.cam[0].T_b_c * p_c0 - p_i).norm() < 1e-9);
  // Stereo baseline recovered in the body frame: 93.97 mm (notes §5.4).
  const double baseline_m = (rig.cam[1].T_b_c.translation() - rig.cam[0].T_b_c.translation()).norm();
  CHECK(baseline_m == Approx(0.09397).epsilon(1e-9));
  CHECK(rig.td_s == 0.0048);
  CHECK(rig.imu.accel_noise_density == 0.00208);
  CHECK(rig.imu.gyro_random_walk == 1.11e-05);
  CHECK(rig.imu.rate_hz == 400.0);
}

TEST_CASE("Kalibr reader names the file and key of a bad value", "[d455][kalibr]") {
  const std::string dir = ums::test::make_temp_dir("d455_kalibr_bad");
  write_chain(dir + "/chain.yaml");
  std::ostringstream buffer;
  buffer << std::ifstream(dir + "/chain.yaml").rdbuf();
  std::string text = buffer.str();
  const auto pos = text.find("camera_model: pinhole");
  text.replace(pos, 21, "camera_model: omni");
  std::ofstream(dir + "/chain.yaml") << text;
  CHECK_THROWS_WITH(read_kalibr(dir + "/chain.yaml", ""), Catch::Contains("chain.yaml: key 'cam0.camera_model'"));
  CHECK_THROWS_WITH(read_kalibr(dir + "/missing.yaml", ""), Catch::Contains("missing.yaml: cannot open"));
}

// Found by tests/fuzz/kalibr_fuzz (a timeout): the reader adds "%YAML:1.0\n---\n" to Kalibr's
// text, and OpenCV 4.6 then loops forever on a root flow sequence followed by block items.
TEST_CASE("Kalibr reader refuses a camchain whose root is not a map, without hanging", "[d455][kalibr][fuzz]") {
  const std::string dir = ums::test::make_temp_dir("d455_kalibr_root");
  std::ofstream(dir + "/chain.yaml") << "  [0]\n  - [-1]\n  c: p\n";
  CHECK_THROWS_WITH(read_kalibr(dir + "/chain.yaml", ""), dir + "/chain.yaml: expected a YAML map of keys");
}

// Found by tests/fuzz/kalibr_fuzz (a timeout inside cv::FileStorage on a form feed).
TEST_CASE("Kalibr reader refuses control characters, without hanging", "[d455][kalibr][fuzz]") {
  const std::string dir = ums::test::make_temp_dir("d455_kalibr_control");
  std::ofstream(dir + "/chain.yaml") << " T:a\nb: -\n\f";
  CHECK_THROWS_WITH(read_kalibr(dir + "/chain.yaml", ""),
                    dir + "/chain.yaml: byte 10 is a control character, not YAML text");
}
