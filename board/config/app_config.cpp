#include "board/config/app_config.hpp"

#include <cmath>
#include <cstdio>
#include <stdexcept>

#include "core/common/capacity.hpp"
#include "hal/replay/yaml_file.hpp"

namespace ums {

namespace {

// One numeric key: its VINS-Fusion name, the AppConfig field it sets, the allowed range and why.
struct NumericKey {
  const char* key;
  const char* field;
  double min, max;
  bool integer;
  const char* unit;
  const char* note;  // appended to the range in messages ("" for none)
  double (*get)(const AppConfig&);
  void (*set)(AppConfig&, double);
};

const NumericKey kNumericKeys[] = {
    {"max_cnt", "max_cnt", 1, static_cast<double>(capacity::kMaxFeaturesPerCamera), true, "features",
     " (capacity::kMaxFeaturesPerCamera)", [](const AppConfig& c) { return double(c.max_cnt); },
     [](AppConfig& c, double v) { c.max_cnt = static_cast<int>(v); }},
    {"detect_min_missing", "detect_min_missing", 1, static_cast<double>(capacity::kMaxFeaturesPerCamera), true,
     "features", " (and <= max_cnt)", [](const AppConfig& c) { return double(c.detect_min_missing); },
     [](AppConfig& c, double v) { c.detect_min_missing = static_cast<int>(v); }},
    {"detect_interval", "detect_interval", 1, 1000, true, "frames", "",
     [](const AppConfig& c) { return double(c.detect_interval); },
     [](AppConfig& c, double v) { c.detect_interval = static_cast<int>(v); }},
    {"klt_sparse_from_level", "klt_sparse_from_level", 0, static_cast<double>(capacity::kMaxPyramidLevels), true, "",
     " (pyramid levels; the last value: none)", [](const AppConfig& c) { return double(c.klt_sparse_from_level); },
     [](AppConfig& c, double v) { c.klt_sparse_from_level = static_cast<int>(v); }},
    {"klt_confirm_sparse_from_level", "klt_confirm_sparse_from_level", 0, static_cast<double>(capacity::kMaxPyramidLevels),
     true, "", " (pyramid levels; the last value: none)",
     [](const AppConfig& c) { return double(c.klt_confirm_sparse_from_level); },
     [](AppConfig& c, double v) { c.klt_confirm_sparse_from_level = static_cast<int>(v); }},
    {"stereo_confirm_tracked", "stereo_confirm_tracked", 0, 1, true, "",
     " (1: a feature matched in the previous frame is also confirmed right->left)",
     [](const AppConfig& c) { return c.stereo_confirm_tracked ? 1.0 : 0.0; },
     [](AppConfig& c, double v) { c.stereo_confirm_tracked = v != 0.0; }},
    {"min_dist", "min_dist_px", 1, 200, false, "px", "", [](const AppConfig& c) { return c.min_dist_px; },
     [](AppConfig& c, double v) { c.min_dist_px = v; }},
    {"F_threshold", "f_threshold_px", 0.01, 10, false, "px", "", [](const AppConfig& c) { return c.f_threshold_px; },
     [](AppConfig& c, double v) { c.f_threshold_px = v; }},
    {"keyframe_parallax", "keyframe_parallax_px", 0.1, 100, false, "px", "",
     [](const AppConfig& c) { return c.keyframe_parallax_px; }, [](AppConfig& c, double v) { c.keyframe_parallax_px = v; }},
    {"max_solver_time", "max_solver_time_s", 0.001, 10, false, "s", "",
     [](const AppConfig& c) { return c.max_solver_time_s; }, [](AppConfig& c, double v) { c.max_solver_time_s = v; }},
    {"max_num_iterations", "max_num_iterations", 1, 100, true, "iterations", "",
     [](const AppConfig& c) { return double(c.max_num_iterations); },
     [](AppConfig& c, double v) { c.max_num_iterations = static_cast<int>(v); }},
    {"round2_min_outlier_share", "round2_min_outlier_share", 0, 1, false, "",
     " (a converged first round is solved again only when its outliers are at least this share of its landmarks)",
     [](const AppConfig& c) { return c.round2_min_outlier_share; },
     [](AppConfig& c, double v) { c.round2_min_outlier_share = v; }},
    {"max_steps_per_solve", "max_steps_per_solve", 0, 2, true, "steps",
     " (0: until converged; a first-round solve makes at most 3 attempts)",
     [](const AppConfig& c) { return double(c.max_steps_per_solve); },
     [](AppConfig& c, double v) { c.max_steps_per_solve = static_cast<int>(v); }},
    {"reuse_gauss_newton_matrix", "reuse_gauss_newton_matrix", 0, 1, true, "", " (1: at a solve's first step only the gradient is formed again)",
     [](const AppConfig& c) { return c.reuse_gauss_newton_matrix ? 1.0 : 0.0; },
     [](AppConfig& c, double v) { c.reuse_gauss_newton_matrix = v != 0.0; }},
    {"reuse_factorization", "reuse_factorization", 0, 1, true, "",
     " (1: the step after that gradient pass is solved with the factor of the step before)",
     [](const AppConfig& c) { return c.reuse_factorization ? 1.0 : 0.0; },
     [](AppConfig& c, double v) { c.reuse_factorization = v != 0.0; }},
    {"max_steps_at_keyframes", "max_steps_at_keyframes", 0, 1, true, "", " (0: keyframe solves run until converged)",
     [](const AppConfig& c) { return c.max_steps_at_keyframes ? 1.0 : 0.0; },
     [](AppConfig& c, double v) { c.max_steps_at_keyframes = v != 0.0; }},
    {"estimate_extrinsic", "estimate_extrinsic", 0, 1, true, "", " (2, calibration from scratch, is not supported)",
     [](const AppConfig& c) { return c.estimate_extrinsic ? 1.0 : 0.0; },
     [](AppConfig& c, double v) { c.estimate_extrinsic = v != 0.0; }},
    {"estimate_td", "estimate_td", 0, 1, true, "", "", [](const AppConfig& c) { return c.estimate_td ? 1.0 : 0.0; },
     [](AppConfig& c, double v) { c.estimate_td = v != 0.0; }},
    {"estimate_gyro_scale", "estimate_gyro_scale", 0, 1, true, "", "",
     [](const AppConfig& c) { return c.estimate_gyro_scale ? 1.0 : 0.0; },
     [](AppConfig& c, double v) { c.estimate_gyro_scale = v != 0.0; }},
    {"td", "rig.td_s", -0.5, 0.5, false, "s", "", [](const AppConfig& c) { return c.rig.td_s; },
     [](AppConfig& c, double v) { c.rig.td_s = v; }},
    {"acc_n", "rig.imu.accel_noise_density", 1e-6, 10, false, "m/s^2/sqrt(Hz)", "",
     [](const AppConfig& c) { return c.rig.imu.accel_noise_density; },
     [](AppConfig& c, double v) { c.rig.imu.accel_noise_density = v; }},
    {"gyr_n", "rig.imu.gyro_noise_density", 1e-7, 10, false, "rad/s/sqrt(Hz)", "",
     [](const AppConfig& c) { return c.rig.imu.gyro_noise_density; },
     [](AppConfig& c, double v) { c.rig.imu.gyro_noise_density = v; }},
    {"acc_w", "rig.imu.accel_random_walk", 1e-8, 10, false, "m/s^3/sqrt(Hz)", "",
     [](const AppConfig& c) { return c.rig.imu.accel_random_walk; },
     [](AppConfig& c, double v) { c.rig.imu.accel_random_walk = v; }},
    {"gyr_w", "rig.imu.gyro_random_walk", 1e-9, 10, false, "rad/s^2/sqrt(Hz)", "",
     [](const AppConfig& c) { return c.rig.imu.gyro_random_walk; },
     [](AppConfig& c, double v) { c.rig.imu.gyro_random_walk = v; }},
    {"imu_noise_scale", "imu_noise_scale", 0.25, 100, false, "", " (times the calibrated densities)",
     [](const AppConfig& c) { return c.imu_noise_scale; }, [](AppConfig& c, double v) { c.imu_noise_scale = v; }},
    {"imu_walk_scale", "imu_walk_scale", 0.25, 100, false, "", " (times the calibrated random walks)",
     [](const AppConfig& c) { return c.imu_walk_scale; }, [](AppConfig& c, double v) { c.imu_walk_scale = v; }},
    {"max_landmarks_in_solve", "max_landmarks_in_solve", 10, static_cast<double>(capacity::kMaxLandmarks), true,
     "landmarks", " (capacity::kMaxLandmarks)", [](const AppConfig& c) { return double(c.max_landmarks_in_solve); },
     [](AppConfig& c, double v) { c.max_landmarks_in_solve = static_cast<int>(v); }},
    {"beta_3d", "beta_3d", 0.01, 100, false, "", "", [](const AppConfig& c) { return c.beta_3d; },
     [](AppConfig& c, double v) { c.beta_3d = v; }},
    {"beta_2d", "beta_2d", 0.01, 100, false, "", "", [](const AppConfig& c) { return c.beta_2d; },
     [](AppConfig& c, double v) { c.beta_2d = v; }},
    {"min_stereo_disparity", "min_stereo_disparity_px", 0, 100, false, "px", "",
     [](const AppConfig& c) { return c.min_stereo_disparity_px; },
     [](AppConfig& c, double v) { c.min_stereo_disparity_px = v; }},
    {"landmark_spread_px", "landmark_spread_px", 0, 2000, false, "px", " (0: off)",
     [](const AppConfig& c) { return c.landmark_spread_px; }, [](AppConfig& c, double v) { c.landmark_spread_px = v; }},
    {"stage_min_2d_left", "stage_min_2d_left", 0, 10000, true, "landmarks", " (0: the paper's comparison always)",
     [](const AppConfig& c) { return double(c.stage_min_2d_left); },
     [](AppConfig& c, double v) { c.stage_min_2d_left = static_cast<int>(v); }},
    {"feature_sigma_px", "feature_sigma_px", 0.1, 20, false, "px", "",
     [](const AppConfig& c) { return c.feature_sigma_px; }, [](AppConfig& c, double v) { c.feature_sigma_px = v; }},
    {"huber_px", "huber_px", 0.1, 50, false, "px", "", [](const AppConfig& c) { return c.huber_px; },
     [](AppConfig& c, double v) { c.huber_px = v; }},
    {"outlier_px", "outlier_px", 0.5, 100, false, "px", "", [](const AppConfig& c) { return c.outlier_px; },
     [](AppConfig& c, double v) { c.outlier_px = v; }},
    {"max_speed_m_s", "max_speed_m_s", 1, 100, false, "m/s", " (divergence guard: a faster estimate resets the window)",
     [](const AppConfig& c) { return c.max_speed_m_s; }, [](AppConfig& c, double v) { c.max_speed_m_s = v; }},
    {"g_norm", "rig.imu.gravity_m_s2", 9.0, 10.5, false, "m/s^2", "",
     [](const AppConfig& c) { return c.rig.imu.gravity_m_s2; },
     [](AppConfig& c, double v) { c.rig.imu.gravity_m_s2 = v; }},
};

// Integer keys that only state the rig's shape: VINS-Fusion's stereo-IMU mode is the only one.
struct FixedKey {
  const char* key;
  int required;
  const char* meaning;
};
const FixedKey kFixedKeys[] = {
    {"imu", 1, "an IMU is required (UMS-VINS is visual-inertial)"},
    {"num_of_cam", 2, "stereo only"},
};

// VINS-Fusion keys accepted and not used: ROS topics, output, threading, display, loop closure.
const char* const kIgnoredKeys[] = {
    "imu_topic", "image0_topic", "image1_topic", "output_path", "multiple_thread", "freq", "show_track",
    "flow_back", "load_previous_pose_graph", "pose_graph_save_path", "save_image", "use_gpu",
    "use_gpu_acc_flow", "use_gpu_ceres", "pose_graph_result_path", "skip_cnt", "skip_dis", "use_imu",
};

const char* const kOtherKeys[] = {"body_T_cam0", "body_T_cam1", "cam0_calib", "cam1_calib", "image_width",
                                  "image_height", "body_T_vehicle"};

std::string format_value(double v) {
  char buf[40];
  std::snprintf(buf, sizeof(buf), "%.10g", v);
  return buf;
}

std::string range_text(const NumericKey& k) {
  std::string text = format_value(k.min) + ".." + format_value(k.max);
  if (k.unit[0] != '\0') text += std::string(" ") + k.unit;
  return text + k.note;
}

bool in_range(const NumericKey& k, double v) {
  return std::isfinite(v) && v >= k.min && v <= k.max && (!k.integer || v == std::floor(v));
}

template <typename T, std::size_t N>
bool contains(const T (&table)[N], const std::string& key) {
  for (const T& entry : table) {
    if (key == entry) return true;
  }
  return false;
}

bool is_numeric_key(const std::string& key) {
  for (const NumericKey& k : kNumericKeys) {
    if (key == k.key) return true;
  }
  return false;
}

bool is_fixed_key(const std::string& key) {
  for (const FixedKey& k : kFixedKeys) {
    if (key == k.key) return true;
  }
  return false;
}

std::string folder_of(const std::string& path) {
  const std::size_t slash = path.rfind('/');
  return slash == std::string::npos ? std::string(".") : path.substr(0, slash);
}

// A camodocal camera file as VINS-Fusion's camN_calib names it (PINHOLE or KANNALA_BRANDT).
void read_camodocal(const std::string& path, CameraCalibration* cam, std::vector<std::string>* warnings) {
  const hal::YamlFile yaml(path);
  const std::string model = yaml.has("model_type") ? yaml.text("model_type") : std::string("PINHOLE");
  const bool pinhole = model == "PINHOLE";
  if (!pinhole && model != "KANNALA_BRANDT") {
    yaml.fail("model_type", "'" + model + "' is not supported (allowed: PINHOLE, KANNALA_BRANDT)");
  }
  for (const std::string& key : yaml.keys()) {
    const bool known = key == "model_type" || key == "camera_name" || key == "image_width" ||
                       key == "image_height" || key == "distortion_parameters" || key == "projection_parameters";
    if (!known && warnings != nullptr) warnings->push_back(path + ": unknown key '" + key + "' ignored");
  }
  const int width = yaml.integer("image_width");
  const int height = yaml.integer("image_height");
  if (width < 1 || width > capacity::kMaxImageWidth) {
    yaml.fail("image_width", "value " + yaml.describe("image_width") + ", allowed 1.." +
                                 std::to_string(capacity::kMaxImageWidth) + " px (capacity::kMaxImageWidth)");
  }
  if (height < 1 || height > capacity::kMaxImageHeight) {
    yaml.fail("image_height", "value " + yaml.describe("image_height") + ", allowed 1.." +
                                  std::to_string(capacity::kMaxImageHeight) + " px (capacity::kMaxImageHeight)");
  }
  cam->width = width;
  cam->height = height;
  if (pinhole) {
    cam->model = CameraModel::kPinholeRadTan;
    cam->distortion = {yaml.number("distortion_parameters.k1"), yaml.number("distortion_parameters.k2"),
                       yaml.number("distortion_parameters.p1"), yaml.number("distortion_parameters.p2")};
    cam->fx = yaml.number("projection_parameters.fx");
    cam->fy = yaml.number("projection_parameters.fy");
    cam->cx = yaml.number("projection_parameters.cx");
    cam->cy = yaml.number("projection_parameters.cy");
  } else {
    // camodocal's Kannala-Brandt: theta_d = theta (1 + k2 theta^2 + k3 theta^4 + k4 theta^6 + k5 theta^8),
    // the equidistant model with our k1..k4 = its k2..k5; mu, mv, u0, v0 = fx, fy, cx, cy.
    cam->model = CameraModel::kPinholeEquidistant;
    cam->distortion = {yaml.number("projection_parameters.k2"), yaml.number("projection_parameters.k3"),
                       yaml.number("projection_parameters.k4"), yaml.number("projection_parameters.k5")};
    cam->fx = yaml.number("projection_parameters.mu");
    cam->fy = yaml.number("projection_parameters.mv");
    cam->cx = yaml.number("projection_parameters.u0");
    cam->cy = yaml.number("projection_parameters.v0");
  }
  const char* focal = pinhole ? "projection_parameters.fx" : "projection_parameters.mu";
  if (!(cam->fx > 0.0 && cam->fy > 0.0)) yaml.fail(focal, "focal lengths must be > 0 px");
}

}  // namespace

void AppConfig::validate() const {
  for (const NumericKey& k : kNumericKeys) {
    const double v = k.get(*this);
    if (!in_range(k, v)) {
      throw std::invalid_argument(std::string("AppConfig.") + k.field + " = " + format_value(v) +
                                  ": allowed " + range_text(k));
    }
  }
  if (detect_min_missing > max_cnt) {
    throw std::invalid_argument("AppConfig.detect_min_missing = " + std::to_string(detect_min_missing) +
                                ": allowed 1..max_cnt (" + std::to_string(max_cnt) + ")");
  }
  for (int side = 0; side < 2; ++side) {
    const CameraCalibration& cam = rig.cam[side];
    if (cam.width < 1 || cam.width > capacity::kMaxImageWidth || cam.height < 1 ||
        cam.height > capacity::kMaxImageHeight) {
      throw std::invalid_argument("AppConfig.rig.cam[" + std::to_string(side) + "] size " +
                                  std::to_string(cam.width) + "x" + std::to_string(cam.height) +
                                  ": allowed 1.." + std::to_string(capacity::kMaxImageWidth) + " x 1.." +
                                  std::to_string(capacity::kMaxImageHeight) + " px");
    }
    if (!(cam.fx > 0.0 && cam.fy > 0.0)) {
      throw std::invalid_argument("AppConfig.rig.cam[" + std::to_string(side) + "] focal length " +
                                  format_value(cam.fx) + ", " + format_value(cam.fy) + ": must be > 0 px");
    }
  }
}

AppConfig config_from_calibration(const RigCalibration& calibration) {
  AppConfig config;
  config.rig = calibration;
  config.source = "sensor.yaml";
  return config;
}

namespace {

void warn_unknown_keys(const hal::YamlFile& yaml, const std::string& path, std::vector<std::string>* warnings) {
  if (warnings == nullptr) return;
  for (const std::string& key : yaml.keys()) {
    const bool known = is_numeric_key(key) || is_fixed_key(key) || contains(kIgnoredKeys, key) ||
                       contains(kOtherKeys, key);
    if (!known) warnings->push_back(path + ": unknown key '" + key + "' ignored");
  }
}

// VINS-Fusion keys this program supports with one value only (e.g. two cameras).
void check_fixed_keys(const hal::YamlFile& yaml) {
  for (const FixedKey& k : kFixedKeys) {
    if (!yaml.has(k.key)) continue;
    bool ok = false;
    try {
      ok = yaml.integer(k.key) == k.required;
    } catch (const std::runtime_error&) {
    }
    if (!ok) {
      yaml.fail(k.key, "value " + yaml.describe(k.key) + ", allowed only " + std::to_string(k.required) + " (" +
                           k.meaning + ")");
    }
  }
}

// Camera models first: camodocal files as VINS-Fusion references them, relative to the config.
void read_camera_models(const hal::YamlFile& yaml, const std::string& path, AppConfig* config,
                        std::vector<std::string>* warnings) {
  for (int side = 0; side < 2; ++side) {
    const std::string key = side == 0 ? "cam0_calib" : "cam1_calib";
    if (!yaml.has(key)) continue;
    std::string file = yaml.text(key);
    if (file.empty()) yaml.fail(key, "empty file name");
    if (file[0] != '/') file = folder_of(path) + "/" + file;
    read_camodocal(file, &config->rig.cam[side], warnings);
  }
}

// image_width / image_height for both cameras, which must agree with their camodocal files.
void read_image_size(const hal::YamlFile& yaml, AppConfig* config) {
  const char* size_keys[2] = {"image_width", "image_height"};
  for (int i = 0; i < 2; ++i) {
    const std::string key = size_keys[i];
    if (!yaml.has(key)) continue;
    const int limit = i == 0 ? capacity::kMaxImageWidth : capacity::kMaxImageHeight;
    int value = 0;
    bool ok = false;
    try {
      value = yaml.integer(key);
      ok = value >= 1 && value <= limit;
    } catch (const std::runtime_error&) {
    }
    if (!ok) {
      yaml.fail(key, "value " + yaml.describe(key) + ", allowed 1.." + std::to_string(limit) + " px (" +
                         (i == 0 ? "capacity::kMaxImageWidth" : "capacity::kMaxImageHeight") + ")");
    }
    for (int side = 0; side < 2; ++side) {
      int& size = i == 0 ? config->rig.cam[side].width : config->rig.cam[side].height;
      const bool from_calib_file = yaml.has(side == 0 ? "cam0_calib" : "cam1_calib");
      if (from_calib_file && size != value) {
        yaml.fail(key, "value " + std::to_string(value) + " differs from cam" + std::to_string(side) +
                           "_calib's " + key + " " + std::to_string(size));
      }
      size = value;
    }
  }
}

// body_T_cam0/1 and the flight controller's mount body_T_vehicle (a rotation, checked).
void read_transforms(const hal::YamlFile& yaml, AppConfig* config) {
  for (int side = 0; side < 2; ++side) {
    const std::string key = side == 0 ? "body_T_cam0" : "body_T_cam1";
    if (yaml.has(key)) config->rig.cam[side].T_b_c = yaml.transform(key);
  }
  if (yaml.has("body_T_vehicle")) {
    config->T_b_vehicle = yaml.transform("body_T_vehicle");
    const Eigen::Matrix3d R = config->T_b_vehicle.linear();
    if ((R.transpose() * R - Eigen::Matrix3d::Identity()).norm() > 1e-6 || R.determinant() < 0.0)
      yaml.fail("body_T_vehicle", "rotation part is not a rotation (orthonormal, det +1)");
  }
}

void read_numeric_keys(const hal::YamlFile& yaml, AppConfig* config) {
  for (const NumericKey& k : kNumericKeys) {
    if (!yaml.has(k.key)) continue;
    double v = 0.0;
    bool ok = false;
    try {
      v = k.integer ? yaml.integer(k.key) : yaml.number(k.key);
      ok = in_range(k, v);
    } catch (const std::runtime_error&) {
    }
    if (!ok) yaml.fail(k.key, "value " + yaml.describe(k.key) + ", allowed " + range_text(k));
    k.set(*config, v);
  }
}

}  // namespace

AppConfig load_config(const std::string& path, const RigCalibration& defaults,
                      std::vector<std::string>* warnings) {
  const hal::YamlFile yaml(path);
  AppConfig config = config_from_calibration(defaults);
  config.source = path;
  warn_unknown_keys(yaml, path, warnings);
  check_fixed_keys(yaml);
  read_camera_models(yaml, path, &config, warnings);
  read_image_size(yaml, &config);
  read_transforms(yaml, &config);
  read_numeric_keys(yaml, &config);
  try {
    config.validate();
  } catch (const std::invalid_argument& e) {
    throw std::runtime_error(path + ": " + e.what());
  }
  return config;
}

}  // namespace ums
