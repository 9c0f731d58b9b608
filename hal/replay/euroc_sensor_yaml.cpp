#include "hal/replay/euroc_sensor_yaml.hpp"

#include <cmath>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <sstream>
#include <stdexcept>

#include "core/common/capacity.hpp"
#include "hal/replay/yaml_file.hpp"

namespace ums::hal {

namespace {

void check_sensor_type(const YamlFile& yaml, const char* expected) {
  if (yaml.has("sensor_type") && yaml.text("sensor_type") != expected) {
    yaml.fail("sensor_type", "expected '" + std::string(expected) + "', got " + yaml.describe("sensor_type"));
  }
}

double positive(const YamlFile& yaml, const std::string& key) {
  const double v = yaml.number(key);
  if (!(v > 0.0)) yaml.fail(key, "must be > 0, got " + yaml.describe(key));
  return v;
}

std::string g17(double v) {
  char buf[40];
  std::snprintf(buf, sizeof(buf), "%.17g", v);
  // Keep a decimal point so the YAML parser reads a real (e.g. "1" -> "1.0").
  if (std::strpbrk(buf, ".eEn") == nullptr) std::strcat(buf, ".0");
  return buf;
}

void write_transform(std::ostream& out, const Eigen::Isometry3d& T) {
  const Eigen::Matrix4d m = T.matrix();
  out << "T_BS:\n  cols: 4\n  rows: 4\n  data: [";
  for (int r = 0; r < 4; ++r) {
    for (int c = 0; c < 4; ++c) {
      out << g17(m(r, c));
      if (r < 3 || c < 3) out << (c == 3 ? ",\n         " : ", ");
    }
  }
  out << "]\n";
}

void write_file(const std::string& path, const std::string& text) {
  std::ofstream file(path, std::ios::binary);
  if (!file) throw std::runtime_error(path + ": cannot create");
  file << text;
  file.close();
  if (!file) throw std::runtime_error(path + ": write failed");
}

}  // namespace

CameraCalibration read_euroc_camera_yaml(const std::string& path) {
  const YamlFile yaml(path);
  check_sensor_type(yaml, "camera");
  CameraCalibration cam;
  cam.T_b_c = yaml.transform("T_BS");
  cam.rate_hz = positive(yaml, "rate_hz");

  const std::vector<double> resolution = yaml.numbers("resolution", 2);
  const double w = resolution[0], h = resolution[1];
  if (w != std::floor(w) || h != std::floor(h) || w < 1 || h < 1 ||
      w > capacity::kMaxImageWidth || h > capacity::kMaxImageHeight) {
    yaml.fail("resolution", "got " + yaml.describe("resolution") + ", allowed [1.." +
                                std::to_string(capacity::kMaxImageWidth) + ", 1.." +
                                std::to_string(capacity::kMaxImageHeight) + "] (capacity::kMaxImageWidth/Height)");
  }
  cam.width = static_cast<int>(w);
  cam.height = static_cast<int>(h);

  if (yaml.has("camera_model") && yaml.text("camera_model") != "pinhole") {
    yaml.fail("camera_model", "only 'pinhole' is supported, got " + yaml.describe("camera_model"));
  }
  const std::vector<double> k = yaml.numbers("intrinsics", 4);
  if (!(k[0] > 0.0 && k[1] > 0.0)) {
    yaml.fail("intrinsics", "fu and fv must be > 0, got " + yaml.describe("intrinsics"));
  }
  cam.fx = k[0];
  cam.fy = k[1];
  cam.cx = k[2];
  cam.cy = k[3];

  const std::string model = yaml.text("distortion_model");
  if (model == "radial-tangential" || model == "radtan") {
    cam.model = CameraModel::kPinholeRadTan;
  } else if (model == "equidistant" || model == "equi") {
    cam.model = CameraModel::kPinholeEquidistant;
  } else {
    yaml.fail("distortion_model", "expected 'radial-tangential' or 'equidistant', got '" + model + "'");
  }
  const std::vector<double> d = yaml.numbers("distortion_coefficients", 4);
  for (int i = 0; i < 4; ++i) cam.distortion[static_cast<std::size_t>(i)] = d[static_cast<std::size_t>(i)];
  return cam;
}

ImuCalibration read_euroc_imu_yaml(const std::string& path) {
  const YamlFile yaml(path);
  check_sensor_type(yaml, "imu");
  ImuCalibration imu;
  imu.T_b_i = yaml.transform("T_BS");
  imu.rate_hz = positive(yaml, "rate_hz");
  imu.gyro_noise_density = positive(yaml, "gyroscope_noise_density");
  imu.gyro_random_walk = positive(yaml, "gyroscope_random_walk");
  imu.accel_noise_density = positive(yaml, "accelerometer_noise_density");
  imu.accel_random_walk = positive(yaml, "accelerometer_random_walk");
  return imu;
}

void write_euroc_camera_yaml(const std::string& path, const CameraCalibration& camera,
                             const std::string& comment) {
  std::ostringstream out;
  out << "%YAML:1.0\n# General sensor definitions.\nsensor_type: camera\ncomment: \"" << comment
      << "\"\n\n# Sensor extrinsics wrt. the body-frame.\n";
  write_transform(out, camera.T_b_c);
  out << "\n# Camera specific definitions.\nrate_hz: " << g17(camera.rate_hz) << "\nresolution: ["
      << camera.width << ", " << camera.height << "]\ncamera_model: pinhole\nintrinsics: ["
      << g17(camera.fx) << ", " << g17(camera.fy) << ", " << g17(camera.cx) << ", " << g17(camera.cy)
      << "] #fu, fv, cu, cv\ndistortion_model: "
      << (camera.model == CameraModel::kPinholeEquidistant ? "equidistant" : "radial-tangential")
      << "\ndistortion_coefficients: [" << g17(camera.distortion[0]) << ", "
      << g17(camera.distortion[1]) << ", " << g17(camera.distortion[2]) << ", "
      << g17(camera.distortion[3]) << "]\n";
  write_file(path, out.str());
}

void write_euroc_imu_yaml(const std::string& path, const ImuCalibration& imu,
                          const std::string& comment) {
  std::ostringstream out;
  out << "%YAML:1.0\nsensor_type: imu\ncomment: \"" << comment
      << "\"\n\n# Sensor extrinsics wrt. the body-frame.\n";
  write_transform(out, imu.T_b_i);
  out << "rate_hz: " << g17(imu.rate_hz) << "\n\n# inertial sensor noise model parameters (static)\n"
      << "gyroscope_noise_density: " << g17(imu.gyro_noise_density) << "     # [ rad / s / sqrt(Hz) ]\n"
      << "gyroscope_random_walk: " << g17(imu.gyro_random_walk) << "       # [ rad / s^2 / sqrt(Hz) ]\n"
      << "accelerometer_noise_density: " << g17(imu.accel_noise_density) << "  # [ m / s^2 / sqrt(Hz) ]\n"
      << "accelerometer_random_walk: " << g17(imu.accel_random_walk) << "    # [ m / s^3 / sqrt(Hz) ]\n";
  write_file(path, out.str());
}

}  // namespace ums::hal
