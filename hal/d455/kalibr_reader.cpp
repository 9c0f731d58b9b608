#include "hal/d455/kalibr_reader.hpp"

#include <cmath>
#include <fstream>
#include <sstream>
#include <stdexcept>
#include <vector>

#include <opencv2/core.hpp>

#include "hal/replay/yaml_file.hpp"

namespace ums::d455 {

namespace {

[[noreturn]] void fail(const std::string& file, const std::string& key, const std::string& problem) {
  throw std::runtime_error(file + ": key '" + key + "': " + problem);
}

std::size_t indent_of(const std::string& line) {
  std::size_t n = 0;
  while (n < line.size() && line[n] == ' ') ++n;
  return n;
}

// Kalibr writes plain YAML: no "%YAML:1.0" directive (cv::FileStorage requires one), and block
// sequences at the same indentation as their key ("T_cam_imu:\n- [..]"), which OpenCV's parser
// refuses; such items are indented by two more spaces.
cv::FileStorage open_yaml(const std::string& path) {
  std::ifstream in(path);
  if (!in) throw std::runtime_error(path + ": cannot open");
  std::string body, line;
  std::size_t key_indent = std::string::npos;  // indentation of a "key:" line awaiting its value
  bool shifting = false;
  while (std::getline(in, line)) {
    const std::size_t ind = indent_of(line);
    const bool item = line.compare(ind, 2, "- ") == 0;
    if (item && (shifting || ind == key_indent)) {
      shifting = ind == key_indent || shifting;
      line.insert(0, "  ");
    } else {
      shifting = false;
    }
    const auto last = line.find_last_not_of(" \r");
    key_indent = (!item && last != std::string::npos && line[last] == ':') ? ind : std::string::npos;
    body += line;
    body += '\n';
  }
  if (!hal::yaml_root_is_map(body)) throw std::runtime_error(path + ": expected a YAML map of keys");
  if (const std::size_t at = hal::yaml_first_control_byte(body); at != std::string::npos) {
    throw std::runtime_error(path + ": byte " + std::to_string(at) + " is a control character, not YAML text");
  }
  if (const std::size_t stray = hal::yaml_first_stray_line(body); stray != 0) {
    throw std::runtime_error(path + ":" + std::to_string(stray) + ": expected \"key: value\" or \"- item\"");
  }
  if (const std::size_t open = hal::yaml_unclosed_flow_line(body); open != 0) {
    throw std::runtime_error(path + ":" + std::to_string(open) + ": YAML syntax error: '[' or '{' never closed");
  }
  if (body.compare(0, 5, "%YAML") != 0) body = "%YAML:1.0\n---\n" + body;
  try {
    cv::FileStorage fs(body, cv::FileStorage::READ | cv::FileStorage::MEMORY | cv::FileStorage::FORMAT_YAML);
    if (!fs.isOpened()) throw std::runtime_error(path + ": not YAML");
    return fs;
  } catch (const cv::Exception& e) {
    throw std::runtime_error(path + ": YAML syntax error: " + e.what());
  }
}

double number(const std::string& file, const cv::FileNode& n, const std::string& key) {
  if (!n.isReal() && !n.isInt()) fail(file, key, "missing or not a number");
  const double v = static_cast<double>(n);
  if (!std::isfinite(v)) fail(file, key, "not finite");
  return v;
}

std::vector<double> list(const std::string& file, const cv::FileNode& n, const std::string& key, std::size_t count) {
  if (!n.isSeq() || n.size() != count) fail(file, key, "expected a list of " + std::to_string(count) + " numbers");
  std::vector<double> out;
  for (std::size_t i = 0; i < count; ++i) out.push_back(number(file, n[static_cast<int>(i)], key));
  return out;
}

// A 4x4 transform written as four rows "- [a, b, c, d]".
Eigen::Isometry3d transform(const std::string& file, const cv::FileNode& n, const std::string& key) {
  if (!n.isSeq() || n.size() != 4) fail(file, key, "expected 4 rows of 4 numbers");
  Eigen::Matrix4d m;
  for (int r = 0; r < 4; ++r) {
    const auto row = list(file, n[r], key, 4);
    for (int c = 0; c < 4; ++c) m(r, c) = row[static_cast<std::size_t>(c)];
  }
  const Eigen::Matrix3d R = m.topLeftCorner<3, 3>();
  if ((R.transpose() * R - Eigen::Matrix3d::Identity()).norm() > 1e-3 ||
      (m.row(3) - Eigen::RowVector4d(0, 0, 0, 1)).norm() > 1e-9) {
    fail(file, key, "not a rigid transform");
  }
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = Eigen::Quaterniond(R).normalized().toRotationMatrix();  // re-orthonormalize Kalibr's 1e-6
  T.translation() = m.topRightCorner<3, 1>();
  return T;
}

}  // namespace

RigCalibration read_kalibr(const std::string& camchain, const std::string& imu_yaml) {
  RigCalibration rig;
  cv::FileStorage fs = open_yaml(camchain);
  double shift[2] = {0.0, 0.0};
  for (int side = 0; side < 2; ++side) {
    const std::string cam = "cam" + std::to_string(side);
    const cv::FileNode node = fs[cam];
    if (node.empty() || !node.isMap()) fail(camchain, cam, "missing (a stereo chain needs cam0 and cam1)");
    CameraCalibration& c = rig.cam[side];
    const std::string model = static_cast<std::string>(node["camera_model"]);
    if (model != "pinhole") fail(camchain, cam + ".camera_model", "'" + model + "' (only pinhole)");
    const auto intr = list(camchain, node["intrinsics"], cam + ".intrinsics", 4);
    c.fx = intr[0];
    c.fy = intr[1];
    c.cx = intr[2];
    c.cy = intr[3];
    const auto res = list(camchain, node["resolution"], cam + ".resolution", 2);
    c.width = static_cast<int>(res[0]);
    c.height = static_cast<int>(res[1]);
    const std::string dist = static_cast<std::string>(node["distortion_model"]);
    if (dist == "radtan") c.model = CameraModel::kPinholeRadTan;
    else if (dist == "equidistant") c.model = CameraModel::kPinholeEquidistant;
    else fail(camchain, cam + ".distortion_model", "'" + dist + "' (radtan or equidistant)");
    const auto d = list(camchain, node["distortion_coeffs"], cam + ".distortion_coeffs", 4);
    for (int i = 0; i < 4; ++i) c.distortion[static_cast<std::size_t>(i)] = d[static_cast<std::size_t>(i)];
    if (!(c.fx > 0 && c.fy > 0 && c.width > 0 && c.height > 0)) fail(camchain, cam + ".intrinsics", "not positive");
    c.T_b_c = transform(camchain, node["T_cam_imu"], cam + ".T_cam_imu").inverse();
    if (!node["timeshift_cam_imu"].empty()) {
      shift[side] = number(camchain, node["timeshift_cam_imu"], cam + ".timeshift_cam_imu");
    }
  }
  rig.td_s = shift[0];
  if (!imu_yaml.empty()) {
    cv::FileStorage ifs = open_yaml(imu_yaml);
    const cv::FileNode imu = ifs["imu0"];
    if (imu.empty() || !imu.isMap()) fail(imu_yaml, "imu0", "missing");
    rig.imu.accel_noise_density = number(imu_yaml, imu["accelerometer_noise_density"], "imu0.accelerometer_noise_density");
    rig.imu.accel_random_walk = number(imu_yaml, imu["accelerometer_random_walk"], "imu0.accelerometer_random_walk");
    rig.imu.gyro_noise_density = number(imu_yaml, imu["gyroscope_noise_density"], "imu0.gyroscope_noise_density");
    rig.imu.gyro_random_walk = number(imu_yaml, imu["gyroscope_random_walk"], "imu0.gyroscope_random_walk");
    rig.imu.rate_hz = number(imu_yaml, imu["update_rate"], "imu0.update_rate");
    if (!imu["T_i_b"].empty()) rig.imu.T_b_i = transform(imu_yaml, imu["T_i_b"], "imu0.T_i_b").inverse();
  }
  return rig;
}

}  // namespace ums::d455
