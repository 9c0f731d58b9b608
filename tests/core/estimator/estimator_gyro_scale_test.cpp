// estimate_gyro_scale end to end on a rendered flight (host only: rendering under qemu is slow).
// The gyro reads up to 1 % too much or too little per axis and nothing else is wrong with the IMU;
// the window's scale block must find the planted factors from the turns, and stay at zero when
// not estimated.

#include <memory>
#include <string>

#include <catch2/catch.hpp>

#include "core/estimator/window.hpp"
#include "hal/replay/euroc_reader.hpp"
#include "hal/sim/simulate.hpp"
#include "tests/common/test_paths.hpp"
#include "tests/core/estimator/dataset_run.hpp"

namespace {

struct ScaleRun {
  Eigen::Vector3d scale = Eigen::Vector3d::Zero();
  bool vio = false;
  std::uint64_t resets = 0;
};

ScaleRun run(const std::string& data, bool estimate) {
  ums::hal::EurocReader reader;
  reader.open(data, ums::hal::EurocReaderOptions());
  const ums::RigCalibration rig = reader.calibration();
  ums::EstimatorOptions eo;
  eo.focal_px = rig.cam[0].fx;
  eo.estimate_gyro_scale = estimate;
  ums::EstimatorOutput out;
  const auto est = ums::test::run_dataset(reader, rig, eo, &out, [](std::int64_t, const ums::EstimatorOutput&) {});
  ScaleRun r;
  r.scale = est->window().gyro_scale().value();
  r.vio = out.mode == ums::EstimatorMode::kVio;
  r.resets = est->stats().resets;
  return r;
}

}  // namespace

TEST_CASE("estimate_gyro_scale: planted gyro scale factors are found on a rendered flight", "[estimator][gyro_scale]") {
  const std::string dir = ums::test::make_temp_dir("gyro_scale_v102");
  ums::sim::SimOptions so;
  so.trajectory_path = ums::test::groundtruth_dir() + "/V102_GT.txt";
  so.duration_s = 20.0;
  so.out_dir = dir + "/data";
  so.imu_model = ums::sim::ImuModel::kRealistic;
  REQUIRE(ums::sim::select_imu_errors("scale", &so.imu_errors));
  so.imu_errors.gyro_scale_max = 0.01;
  so.imu_errors.accel_scale_max = 0.0;
  const ums::sim::ImuErrorDraw draw = ums::sim::draw_imu_errors(so.imu_errors, so.seed);
  std::string error;
  REQUIRE(ums::sim::simulate(so, &error) == 0);
  const ScaleRun fixed = run(so.out_dir, false);
  const ScaleRun free = run(so.out_dir, true);
  INFO("planted " << 100.0 * draw.gyro_scale.transpose() << " %, estimated " << 100.0 * free.scale.transpose() << " %");
  CHECK(fixed.scale == Eigen::Vector3d::Zero());  // not estimated: held at zero bit for bit
  CHECK(free.vio);
  CHECK(free.resets == 0);
  // V102's turns excite every axis: each factor within 0.25 % (a quarter of the largest planted).
  CHECK((free.scale - draw.gyro_scale).cwiseAbs().maxCoeff() < 0.0025);
}
