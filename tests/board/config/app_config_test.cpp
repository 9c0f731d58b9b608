#include "board/config/app_config.hpp"

#include <catch2/catch.hpp>
#include <cstring>
#include <fstream>

#include "core/common/capacity.hpp"
#include "core/estimator/estimator_options.hpp"
#include "core/frontend/frontend.hpp"
#include "hal/replay/euroc_sensor_yaml.hpp"
#include "tests/common/test_paths.hpp"

namespace {

// A VINS-Fusion stereo-IMU config for EuRoC, written from the key list (values of the EuRoC rig).
const char* const kVinsConfig = R"(%YAML:1.0

#common parameters
imu: 1
num_of_cam: 2

imu_topic: "/imu0"
image0_topic: "/cam0/image_raw"
image1_topic: "/cam1/image_raw"
output_path: "/tmp/vins_output/"

cam0_calib: "cam0_pinhole.yaml"
cam1_calib: "cam1_pinhole.yaml"
image_width: 752
image_height: 480

# Extrinsic parameter between IMU and Camera.
estimate_extrinsic: 1   # 0 fixed, 1 refine around the guess

body_T_cam0: !!opencv-matrix
   rows: 4
   cols: 4
   dt: d
   data: [0.0148655429818, -0.999880929698, 0.00414029679422, -0.0216401454975,
           0.999557249008, 0.0149672133247, 0.025715529948, -0.064676986768,
           -0.0257744366974, 0.00375618835797, 0.999660727178, 0.00981073058949,
           0, 0, 0, 1]

body_T_cam1: !!opencv-matrix
   rows: 4
   cols: 4
   dt: d
   data: [0.0125552670891, -0.999755099723, 0.0182237714554, -0.0198435579556,
           0.999598781151, 0.0130119051815, 0.0251588363115, 0.0453689425024,
           -0.0253898008918, 0.0179005838253, 0.999517347078, 0.00786212447038,
           0, 0, 0, 1]

multiple_thread: 1

#feature traker paprameters
max_cnt: 150
min_dist: 30
freq: 10
F_threshold: 1.0
show_track: 1
flow_back: 1

#optimization parameters
max_solver_time: 0.04
max_num_iterations: 8
keyframe_parallax: 10.0

#imu parameters
acc_n: 0.1
gyr_n: 0.01
acc_w: 0.001
gyr_w: 0.0001
g_norm: 9.81007

#unsynchronization parameters
estimate_td: 0
td: 0.0

#loop closure parameters
load_previous_pose_graph: 0
pose_graph_save_path: "/tmp/vins_output/pose_graph/"
save_image: 0
)";

const char* const kCam0Pinhole = R"(%YAML:1.0
---
model_type: PINHOLE
camera_name: camera
image_width: 752
image_height: 480
distortion_parameters:
   k1: -2.917e-01
   k2: 8.228e-02
   p1: 5.333e-05
   p2: -1.578e-04
projection_parameters:
   fx: 4.616e+02
   fy: 4.603e+02
   cx: 3.630e+02
   cy: 2.481e+02
)";

const char* const kCam1Pinhole = R"(%YAML:1.0
---
model_type: PINHOLE
camera_name: camera
image_width: 752
image_height: 480
distortion_parameters:
   k1: -2.917e-01
   k2: 8.228e-02
   p1: 5.333e-05
   p2: -1.578e-04
projection_parameters:
   fx: 4.616e+02
   fy: 4.603e+02
   cx: 3.630e+02
   cy: 2.481e+02
)";

void write_text(const std::string& path, const std::string& text) { std::ofstream(path) << text; }

std::string write_vins_config(const std::string& dir, const std::string& text = kVinsConfig) {
  write_text(dir + "/cam0_pinhole.yaml", kCam0Pinhole);
  write_text(dir + "/cam1_pinhole.yaml", kCam1Pinhole);
  write_text(dir + "/euroc_stereo_imu_config.yaml", text);
  return dir + "/euroc_stereo_imu_config.yaml";
}

ums::RigCalibration micro_calibration() {
  const std::string mav0 = ums::test::euroc_micro_dir() + "/mav0";
  ums::RigCalibration rig;
  rig.cam[0] = ums::hal::read_euroc_camera_yaml(mav0 + "/cam0/sensor.yaml");
  rig.cam[1] = ums::hal::read_euroc_camera_yaml(mav0 + "/cam1/sensor.yaml");
  rig.imu = ums::hal::read_euroc_imu_yaml(mav0 + "/imu0/sensor.yaml");
  return rig;
}

std::string load_error(const std::string& path, std::vector<std::string>* warnings = nullptr) {
  try {
    ums::load_config(path, micro_calibration(), warnings);
  } catch (const std::exception& e) {
    return e.what();
  }
  return "";
}

std::string replace(std::string text, const std::string& from, const std::string& to) {
  const std::size_t at = text.find(from);
  REQUIRE(at != std::string::npos);
  return text.replace(at, from.size(), to);
}

}  // namespace

TEST_CASE("config from the dataset's calibration keeps it and the defaults", "[config]") {
  const ums::RigCalibration rig = micro_calibration();
  const ums::AppConfig config = ums::config_from_calibration(rig);
  CHECK(config.rig.cam[0].fx == 458.654);
  CHECK(config.rig.imu.accel_noise_density == 2.0e-3);
  CHECK(config.max_cnt == 200);
  CHECK(config.min_dist_px == 25.0);
  CHECK(config.f_threshold_px == 1.0);
  CHECK(config.keyframe_parallax_px == 10.0);
  CHECK(config.source == "sensor.yaml");
  CHECK_NOTHROW(config.validate());
}

TEST_CASE("the KLT's sparse levels, the stereo confirmation and the detection interval are keys, and without them the front end's defaults hold", "[config]") {
  const std::string dir = ums::test::make_temp_dir("config_klt_sparse");
  std::vector<std::string> warnings;
  const ums::AppConfig c = ums::load_config(
      write_vins_config(dir, std::string(kVinsConfig) +
                                 "klt_sparse_from_level: 2\nklt_confirm_sparse_from_level: 1\nstereo_confirm_tracked: 1\n"
                                 "detect_interval: 3\n"),
      micro_calibration(), &warnings);
  CHECK(warnings.empty());
  CHECK(c.klt_sparse_from_level == 2);
  CHECK(c.klt_confirm_sparse_from_level == 1);
  CHECK(c.stereo_confirm_tracked);
  CHECK(c.detect_interval == 3);
  const ums::AppConfig d = ums::config_from_calibration(micro_calibration());
  CHECK(d.klt_sparse_from_level == ums::FrontendOptions{}.klt.sparse_from_level);
  CHECK(d.klt_confirm_sparse_from_level == ums::FrontendOptions{}.confirm_sparse_from_level);
  CHECK(d.stereo_confirm_tracked == ums::FrontendOptions{}.stereo_confirm_tracked);
  CHECK(d.detect_interval == ums::FrontendOptions{}.detect_interval);
}

TEST_CASE("a VINS-Fusion stereo-IMU config is read with its camodocal files and no warnings", "[config]") {
  const std::string path = write_vins_config(ums::test::make_temp_dir("config_vins"));
  std::vector<std::string> warnings;
  const ums::AppConfig c = ums::load_config(path, micro_calibration(), &warnings);
  CHECK(warnings.empty());
  CHECK(c.source == path);
  CHECK(c.max_cnt == 150);
  CHECK(c.min_dist_px == 30.0);
  CHECK(c.f_threshold_px == 1.0);
  CHECK(c.keyframe_parallax_px == 10.0);
  CHECK(c.max_solver_time_s == 0.04);
  CHECK(c.max_num_iterations == 8);
  CHECK(c.estimate_extrinsic);
  CHECK_FALSE(c.estimate_td);
  CHECK(c.rig.td_s == 0.0);
  CHECK(c.rig.imu.accel_noise_density == 0.1);
  CHECK(c.rig.imu.gyro_noise_density == 0.01);
  CHECK(c.rig.imu.accel_random_walk == 0.001);
  CHECK(c.rig.imu.gyro_random_walk == 0.0001);
  CHECK(c.rig.imu.gravity_m_s2 == 9.81007);
  // Intrinsics from cam0_pinhole.yaml replace sensor.yaml's (458.654 -> 461.6).
  CHECK(c.rig.cam[0].fx == 461.6);
  CHECK(c.rig.cam[0].cy == 248.1);
  CHECK(c.rig.cam[0].distortion[0] == -0.2917);
  CHECK(c.rig.cam[0].distortion[3] == -1.578e-04);
  CHECK(c.rig.cam[0].model == ums::CameraModel::kPinholeRadTan);
  CHECK(c.rig.cam[1].width == 752);
  CHECK(c.rig.cam[0].T_b_c.translation().x() == -0.0216401454975);
  CHECK(c.rig.cam[1].T_b_c.translation().y() == 0.0453689425024);
  // Keys the file does not set keep the dataset's values.
  CHECK(c.rig.cam[0].rate_hz == 20.0);
}

TEST_CASE("the back end's weights are keys of their own", "[config]") {
  const std::string dir = ums::test::make_temp_dir("config_weights");
  const std::string path = write_vins_config(
      dir, std::string(kVinsConfig) +
               "imu_noise_scale: 3.5\nimu_walk_scale: 8\nmax_landmarks_in_solve: 200\nbeta_3d: 1.5\nbeta_2d: 0.5\nmin_stereo_disparity: 2\n"
               "landmark_spread_px: 80\nstage_min_2d_left: 0\nfeature_sigma_px: 2\nhuber_px: 1\noutlier_px: 4\n"
               "max_speed_m_s: 35\nmax_steps_per_solve: 2\nmax_steps_at_keyframes: 1\nreuse_gauss_newton_matrix: 0\nreuse_factorization: 0\n"
               "round2_min_outlier_share: 0.05\n");
  std::vector<std::string> warnings;
  const ums::AppConfig c = ums::load_config(path, micro_calibration(), &warnings);
  CHECK(warnings.empty());
  CHECK(c.imu_noise_scale == 3.5);
  CHECK(c.imu_walk_scale == 8.0);
  CHECK(c.max_landmarks_in_solve == 200);
  CHECK(c.beta_3d == 1.5);
  CHECK(c.beta_2d == 0.5);
  CHECK(c.min_stereo_disparity_px == 2.0);
  CHECK(c.landmark_spread_px == 80.0);
  CHECK(c.stage_min_2d_left == 0);
  CHECK(c.feature_sigma_px == 2.0);
  CHECK(c.huber_px == 1.0);
  CHECK(c.outlier_px == 4.0);
  CHECK(c.max_speed_m_s == 35.0);
  CHECK(c.max_steps_per_solve == 2);
  CHECK(c.max_steps_at_keyframes);
  CHECK_FALSE(c.reuse_gauss_newton_matrix);
  CHECK_FALSE(c.reuse_factorization);
  CHECK(c.round2_min_outlier_share == 0.05);
  // Without the keys: the defaults (docs/results.md, "Weights", has the measurements behind them).
  const ums::AppConfig d = ums::load_config(write_vins_config(ums::test::make_temp_dir("config_weights_default"),
                                                              kVinsConfig),
                                            micro_calibration(), &warnings);
  CHECK(d.max_landmarks_in_solve == 150);
  CHECK(d.stage_min_2d_left == 10);
  CHECK(d.landmark_spread_px == 0.0);
  // One step per solve but at keyframes, whose solves run until converged; the second
  // linearization a gradient pass (docs/performance.md, session 28).
  CHECK(d.max_steps_per_solve == 1);
  CHECK(d.max_steps_per_solve == ums::EstimatorOptions{}.max_steps_stage);
  CHECK_FALSE(d.max_steps_at_keyframes);
  CHECK(d.max_steps_at_keyframes == ums::EstimatorOptions{}.max_steps_at_keyframes);
  CHECK(d.reuse_gauss_newton_matrix);
  CHECK(d.reuse_gauss_newton_matrix == ums::EstimatorOptions{}.reuse_gauss_newton_matrix);
  // The step after the gradient pass from the step before's factor (docs/performance.md, session 35).
  CHECK(d.reuse_factorization);
  CHECK(d.reuse_factorization == ums::EstimatorOptions{}.reuse_factorization);
  // The speed guard's default is the estimator's (20 m/s = 72 km/h), far above a car at 15-25 km/h
  // (6.9 m/s, the simulator's car scenarios) or a drone.
  CHECK(d.max_speed_m_s == ums::EstimatorOptions{}.max_speed_m_s);
  CHECK(d.max_speed_m_s > 25.0 / 3.6 * 2.0);
}

TEST_CASE("body_T_vehicle sets the MAVLink mount, a matrix that is no rotation is refused", "[config]") {
  const std::string mount = "body_T_vehicle: !!opencv-matrix\n   rows: 4\n   cols: 4\n   dt: d\n"
                            "   data: [ 0.0, 1.0, 0.0, 0.1,\n           0.0, 0.0, 1.0, 0.0,\n"
                            "           1.0, 0.0, 0.0, 0.0,\n           0.0, 0.0, 0.0, 1.0 ]\n";
  std::vector<std::string> warnings;
  const ums::AppConfig c = ums::load_config(
      write_vins_config(ums::test::make_temp_dir("config_vehicle"), std::string(kVinsConfig) + mount),
      micro_calibration(), &warnings);
  CHECK(warnings.empty());
  CHECK(c.T_b_vehicle.linear()(0, 1) == 1.0);  // the vehicle's y (right) is the body's x
  CHECK(c.T_b_vehicle.linear()(2, 0) == 1.0);  // its x (forward) the body's z
  std::string mirrored = mount;
  mirrored.replace(mirrored.find("1.0, 0.0, 0.0, 0.0,"), 3, "-1.");  // det -1: a mirror image
  CHECK_THROWS_WITH(ums::load_config(write_vins_config(ums::test::make_temp_dir("config_vehicle_bad"),
                                                       std::string(kVinsConfig) + mirrored),
                                     micro_calibration(), &warnings),
                    Catch::Contains("body_T_vehicle") && Catch::Contains("not a rotation"));
  const ums::AppConfig d = ums::load_config(
      write_vins_config(ums::test::make_temp_dir("config_vehicle_default"), kVinsConfig), micro_calibration(), &warnings);
  CHECK(d.T_b_vehicle.linear().isIdentity());
}

TEST_CASE("unknown keys warn with file and key, known VINS keys are silent", "[config]") {
  const std::string dir = ums::test::make_temp_dir("config_unknown");
  const std::string path = write_vins_config(dir, std::string(kVinsConfig) + "max_cnt_typo: 3\nuse_magic: 1\n");
  std::vector<std::string> warnings;
  ums::load_config(path, micro_calibration(), &warnings);
  REQUIRE(warnings.size() == 2);
  CHECK(warnings[0] == path + ": unknown key 'max_cnt_typo' ignored");
  CHECK(warnings[1] == path + ": unknown key 'use_magic' ignored");
}

TEST_CASE("each invalid value stops with file, key, value and the allowed range", "[config]") {
  const std::string dir = ums::test::make_temp_dir("config_invalid");
  struct Case {
    const char* from;
    const char* to;
    const char* message;
  };
  const std::string max_features = std::to_string(ums::capacity::kMaxFeaturesPerCamera);
  const std::string max_cnt_message =
      "key 'max_cnt': value 5000, allowed 1.." + max_features + " features (capacity::kMaxFeaturesPerCamera)";
  const Case cases[] = {
      {"max_cnt: 150", "max_cnt: 5000", max_cnt_message.c_str()},
      {"max_cnt: 150", "max_cnt: 0", "key 'max_cnt': value 0, allowed 1.."},
      {"max_cnt: 150", "max_cnt: 150.5", "key 'max_cnt': value 150.5, allowed 1.."},
      {"max_cnt: 150", "max_cnt: many", "key 'max_cnt': value 'many', allowed 1.."},
      {"max_cnt: 150", "max_cnt: 150\ndetect_min_missing: 0", "key 'detect_min_missing': value 0, allowed 1.."},
      {"max_cnt: 150", "max_cnt: 150\ndetect_interval: 0", "key 'detect_interval': value 0, allowed 1..1000 frames"},
      {"max_cnt: 150", "max_cnt: 150\nklt_sparse_from_level: 5", "key 'klt_sparse_from_level': value 5, allowed 0..4"},
      {"max_cnt: 150", "max_cnt: 150\nklt_confirm_sparse_from_level: -1",
       "key 'klt_confirm_sparse_from_level': value -1, allowed 0..4"},
      {"min_dist: 30", "min_dist: -3", "key 'min_dist': value -3, allowed 1..200 px"},
      {"F_threshold: 1.0", "F_threshold: 0", "key 'F_threshold': value 0, allowed 0.01..10 px"},
      {"keyframe_parallax: 10.0", "keyframe_parallax: 1000", "key 'keyframe_parallax': value 1000, allowed 0.1..100 px"},
      {"max_solver_time: 0.04", "max_solver_time: 0", "key 'max_solver_time': value 0, allowed 0.001..10 s"},
      {"max_num_iterations: 8", "max_num_iterations: 0", "key 'max_num_iterations': value 0, allowed 1..100"},
      {"max_num_iterations: 8", "max_num_iterations: 8\nmax_steps_per_solve: -1",
       "key 'max_steps_per_solve': value -1, allowed 0..2"},
      {"max_num_iterations: 8", "max_num_iterations: 8\nmax_steps_per_solve: 3",
       "key 'max_steps_per_solve': value 3, allowed 0..2"},
      {"max_num_iterations: 8", "max_num_iterations: 8\nmax_steps_at_keyframes: 2",
       "key 'max_steps_at_keyframes': value 2, allowed 0..1 (0: keyframe solves run until converged)"},
      {"max_num_iterations: 8", "max_num_iterations: 8\nreuse_gauss_newton_matrix: 0.5",
       "key 'reuse_gauss_newton_matrix': value 0.5, allowed 0..1"},
      {"estimate_extrinsic: 1", "estimate_extrinsic: 2",
       "key 'estimate_extrinsic': value 2, allowed 0..1 (2, calibration from scratch, is not supported)"},
      {"estimate_td: 0", "estimate_td: 3", "key 'estimate_td': value 3, allowed 0..1"},
      {"td: 0.0", "td: 2.0", "key 'td': value 2, allowed -0.5..0.5 s"},
      {"acc_n: 0.1", "acc_n: 0", "key 'acc_n': value 0, allowed 1e-06..10 m/s^2/sqrt(Hz)"},
      {"gyr_n: 0.01", "gyr_n: -0.01", "key 'gyr_n': value -0.01, allowed 1e-07..10 rad/s/sqrt(Hz)"},
      {"acc_w: 0.001", "acc_w: 20", "key 'acc_w': value 20, allowed 1e-08..10"},
      {"gyr_w: 0.0001", "gyr_w: 0", "key 'gyr_w': value 0, allowed 1e-09..10"},
      {"g_norm: 9.81007", "g_norm: 1.62", "key 'g_norm': value 1.62, allowed 9..10.5 m/s^2"},
      {"image_width: 752", "image_width: 4000", "key 'image_width': value 4000, allowed 1..1280 px"},
      {"image_height: 480", "image_height: 400", "key 'image_height': value 400 differs from cam0_calib's image_height 480"},
      {"num_of_cam: 2", "num_of_cam: 1", "key 'num_of_cam': value 1, allowed only 2 (stereo only)"},
      {"imu: 1", "imu: 0", "key 'imu': value 0, allowed only 1"},
      {"0, 0, 0, 1]\n\nbody_T_cam1", "0, 0, 0, 2]\n\nbody_T_cam1", "key 'body_T_cam0': last row must be [0, 0, 0, 1]"},
      {"   rows: 4\n   cols: 4\n   dt: d\n   data: [0.0125", "   rows: 3\n   cols: 4\n   dt: d\n   data: [0.0125",
       "key 'body_T_cam1': expected a 4x4 matrix"},
      {"cam1_calib: \"cam1_pinhole.yaml\"", "cam1_calib: \"cam1_missing.yaml\"", "cam1_missing.yaml: cannot open"},
      {"max_cnt: 150", "max_cnt: [150", "euroc_stereo_imu_config.yaml:"},
      {"max_cnt: 150", "max_cnt: 150\nimu_noise_scale: 0", "key 'imu_noise_scale': value 0, allowed 0.25..100"},
      {"max_cnt: 150", "max_cnt: 150\nmax_landmarks_in_solve: 5", "key 'max_landmarks_in_solve': value 5, allowed 10.."},
      {"max_cnt: 150", "max_cnt: 150\nbeta_2d: 0", "key 'beta_2d': value 0, allowed 0.01..100"},
      {"max_cnt: 150", "max_cnt: 150\nmin_stereo_disparity: -1", "key 'min_stereo_disparity': value -1, allowed 0..100 px"},
      {"max_cnt: 150", "max_cnt: 150\nmax_speed_m_s: 0.5", "key 'max_speed_m_s': value 0.5, allowed 1..100 m/s"},
      {"max_cnt: 150", "max_cnt: 150\nmax_speed_m_s: 150", "key 'max_speed_m_s': value 150, allowed 1..100 m/s"},
  };
  for (const Case& c : cases) {
    CAPTURE(c.to);
    const std::string path = write_vins_config(dir, replace(kVinsConfig, c.from, c.to));
    const std::string error = load_error(path);
    CHECK_THAT(error, Catch::Contains(c.message));
    if (std::strstr(c.message, "key '") != nullptr) CHECK_THAT(error, Catch::StartsWith(path + ": key '"));
  }
}

TEST_CASE("camodocal files: KANNALA_BRANDT maps to equidistant, other models and bad values are refused", "[config]") {
  const std::string dir = ums::test::make_temp_dir("config_camodocal");
  const std::string path = write_vins_config(dir);
  write_text(dir + "/cam1_pinhole.yaml",
             "%YAML:1.0\n---\nmodel_type: KANNALA_BRANDT\ncamera_name: camera\nimage_width: 752\nimage_height: 480\n"
             "projection_parameters:\n   k2: -0.01\n   k3: 0.02\n   k4: -0.003\n   k5: 0.0004\n   mu: 380.1\n"
             "   mv: 380.2\n   u0: 376.0\n   v0: 240.5\n");
  const ums::AppConfig c = ums::load_config(path, micro_calibration(), nullptr);
  CHECK(c.rig.cam[1].model == ums::CameraModel::kPinholeEquidistant);
  CHECK(c.rig.cam[1].fx == 380.1);
  CHECK(c.rig.cam[1].cy == 240.5);
  CHECK(c.rig.cam[1].distortion == std::array<double, 4>{-0.01, 0.02, -0.003, 0.0004});

  write_text(dir + "/cam1_pinhole.yaml", "%YAML:1.0\nmodel_type: MEI\nimage_width: 752\nimage_height: 480\n");
  CHECK_THAT(load_error(path), Catch::Contains("cam1_pinhole.yaml: key 'model_type': 'MEI' is not supported"));
  write_text(dir + "/cam1_pinhole.yaml", replace(kCam1Pinhole, "fy: 4.603e+02", "fy: abc"));
  CHECK_THAT(load_error(path), Catch::Contains("cam1_pinhole.yaml: key 'projection_parameters.fy': expected a number, got 'abc'"));
  write_text(dir + "/cam1_pinhole.yaml", replace(kCam1Pinhole, "   p2: -1.578e-04\n", ""));
  CHECK_THAT(load_error(path), Catch::Contains("cam1_pinhole.yaml: key 'distortion_parameters.p2': missing"));
}

TEST_CASE("config without %YAML directive, and a missing config file", "[config]") {
  const std::string dir = ums::test::make_temp_dir("config_misc");
  write_text(dir + "/plain.yaml", "max_cnt: 120\ng_norm: 9.8\n");
  const ums::AppConfig c = ums::load_config(dir + "/plain.yaml", micro_calibration(), nullptr);
  CHECK(c.max_cnt == 120);
  CHECK(c.rig.imu.gravity_m_s2 == 9.8);
  CHECK(c.rig.cam[0].fx == 458.654);  // untouched
  CHECK_THAT(load_error(dir + "/none.yaml"), Catch::Contains("none.yaml: cannot open"));
}

TEST_CASE("AppConfig::validate names the field, value and range", "[config]") {
  ums::AppConfig c = ums::config_from_calibration(micro_calibration());
  c.max_cnt = 401;
  CHECK_THROWS_WITH(c.validate(), Catch::Contains("AppConfig.max_cnt = 401: allowed 1..400"));
  c = ums::config_from_calibration(micro_calibration());
  c.detect_min_missing = c.max_cnt + 1;
  CHECK_THROWS_WITH(c.validate(), Catch::Contains("AppConfig.detect_min_missing = 201: allowed 1..max_cnt (200)"));
  c.detect_min_missing = 10;
  CHECK_NOTHROW(c.validate());
  c = ums::config_from_calibration(micro_calibration());
  c.rig.imu.gravity_m_s2 = 0;
  CHECK_THROWS_WITH(c.validate(), Catch::Contains("AppConfig.rig.imu.gravity_m_s2 = 0: allowed 9..10.5 m/s^2"));
  c = ums::config_from_calibration(micro_calibration());
  c.rig.cam[1].width = 0;
  CHECK_THROWS_WITH(c.validate(), Catch::Contains("AppConfig.rig.cam[1] size 0x480"));
}
