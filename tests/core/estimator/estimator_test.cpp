#include "core/estimator/estimator.hpp"

#include <cmath>
#include <memory>

#include <catch2/catch.hpp>

#include "core/frontend/frontend.hpp"
#include "core/imu/saturation.hpp"
#include "hal/replay/euroc_reader.hpp"
#include "profiling/alloc_counter.hpp"
#include "tests/common/test_paths.hpp"

namespace {

struct MicroRun {
  std::vector<ums::EstimatorOutput> outputs;
  ums::EstimatorStats stats;
  std::uint64_t steady_allocations = 0;
};

// The real EuRoC micro sequence (V1_01, the vehicle standing on the floor) through the front end
// and the estimator, as the replay pipeline does (without its gyro hint: nothing moves).
MicroRun run_micro() {
  ums::hal::EurocReader reader;
  reader.open(ums::test::euroc_micro_dir(), ums::hal::EurocReaderOptions());
  const ums::RigCalibration rig = reader.calibration();
  ums::FrontendOptions fo;
  auto frontend = std::make_unique<ums::Frontend>(fo, rig);
  ums::EstimatorOptions eo;
  eo.focal_px = rig.cam[0].fx;
  auto estimator = std::make_unique<ums::Estimator>(eo, rig);
  auto features = std::make_unique<ums::FrameFeatures>();
  ums::SaturationElement saturation;
  MicroRun run;
  run.outputs.reserve(200);
  ums::ImuSample imu;
  ums::StereoFrame frame;
  for (;;) {
    const auto ev = reader.next(&imu, &frame);
    if (ev == ums::hal::EurocReader::Event::kEnd) break;
    const bool steady = run.outputs.size() >= 50;
    ums::AllocScope scope;
    if (ev == ums::hal::EurocReader::Event::kImu) {
      ums::ImuSample clipped;
      saturation.apply(imu, &clipped);
      estimator->add_imu(clipped);
    } else if (frontend->process(frame, nullptr, features.get()) == ums::Status::kOk) {
      ums::EstimatorOutput out;
      estimator->add_frame(*features, &out, nullptr);
      if (steady) run.steady_allocations += scope.allocations();
      run.outputs.push_back(out);
      continue;
    }
    if (steady) run.steady_allocations += scope.allocations();
  }
  run.stats = estimator->stats();
  return run;
}

// A rig with only focal lengths (identity extrinsics) and a 200 Hz IMU stream from t = 1 s.
ums::RigCalibration bare_rig() {
  ums::RigCalibration rig;
  rig.cam[0].fx = rig.cam[0].fy = 460.0;
  rig.cam[1] = rig.cam[0];
  return rig;
}

template <typename Fill>
void feed_imu(ums::Estimator* est, int n, Fill fill) {
  for (int k = 0; k < n; ++k) {
    ums::ImuSample s;
    s.t_ns = 1'000'000'000 + static_cast<std::int64_t>(k) * 5'000'000;
    fill(k, &s);
    est->add_imu(s);
  }
}

}  // namespace

TEST_CASE("estimator on the real EuRoC micro sequence at rest: initializes within 1 s, holds still, 0 allocations", "[estimator]") {
  const MicroRun run = run_micro();
  REQUIRE(run.outputs.size() == 95);
  const double init_s = static_cast<double>(run.stats.init_t_ns - run.stats.first_frame_t_ns) * 1e-9;
  INFO("initialized " << run.stats.initialized << " at " << init_s << " s (" << run.stats.init_case << ")");
  REQUIRE(run.stats.initialized);
  CHECK(init_s <= 1.0);
  CHECK(std::string(run.stats.init_case) == "standstill");
  int poses = 0;
  double max_drift_m = 0.0;
  const Eigen::Vector3d p0 = run.outputs.front().p_w_b;
  for (const ums::EstimatorOutput& o : run.outputs) {
    if (!o.valid) continue;
    ++poses;
    max_drift_m = std::max(max_drift_m, (o.p_w_b - p0).norm());
  }
  INFO("poses " << poses << ", largest distance from the start " << max_drift_m << " m");
  CHECK(poses >= 80);
  CHECK(max_drift_m <= 0.02);
  CHECK(run.outputs.back().mode == ums::EstimatorMode::kVio);
  // Gravity: at rest the estimated attitude levels the mean accelerometer reading (world z up)
  // and the velocity stays near zero.
  CHECK(run.outputs.back().v_w_b.norm() < 0.02);
  CHECK(run.steady_allocations == 0);
  CHECK(run.stats.drops_landmarks == 0);
  CHECK(run.stats.drops_residuals == 0);
}

TEST_CASE("estimator: invalid options are refused at start-up", "[estimator]") {
  ums::RigCalibration rig;
  ums::EstimatorOptions o;
  o.window_size = 100;  // above capacity::kWindowSize
  CHECK_THROWS_AS(ums::Estimator(o, rig), std::invalid_argument);
  o = ums::EstimatorOptions();
  o.sigma_px = 0.0;
  CHECK_THROWS_AS(ums::Estimator(o, rig), std::invalid_argument);
}

TEST_CASE("estimator: IMU_ONLY gives no pose while the velocity is unknown (moving, no vision)", "[estimator]") {
  ums::Estimator est(ums::EstimatorOptions(), bare_rig());
  // Accelerating and turning: never at rest, and no features (dark images).
  feed_imu(&est, 200, [](int k, ums::ImuSample* s) {
    s->accel_m_s2 = Eigen::Vector3d(1.0 * std::sin(0.05 * k), 0.5, 9.81);
    s->gyro_rad_s = Eigen::Vector3d(0.0, 0.0, 0.5 * std::cos(0.07 * k));
  });
  auto ff = std::make_unique<ums::FrameFeatures>();
  ff->t_ns = 1'900'000'000;
  ums::EstimatorOutput out;
  est.add_frame(*ff, &out, nullptr);
  CHECK_FALSE(out.valid);
  CHECK(out.mode == ums::EstimatorMode::kImuOnly);
  CHECK(est.stats().frames_without_pose == 1);
  ums::NavState nav;
  CHECK_FALSE(est.imu_rate_state(&nav));
}

TEST_CASE("estimator: a frame not after the previous one is counted and not processed", "[estimator]") {
  ums::Estimator est(ums::EstimatorOptions(), bare_rig());
  feed_imu(&est, 200, [](int, ums::ImuSample* s) { s->accel_m_s2 = Eigen::Vector3d(0.0, 0.0, 9.81); });  // at rest
  auto ff = std::make_unique<ums::FrameFeatures>();
  ff->t_ns = 1'900'000'000;
  ums::EstimatorOutput out;
  est.add_frame(*ff, &out, nullptr);
  CHECK(out.valid);  // at rest for 0.9 s: attitude from gravity, zero velocity: IMU_ONLY pose
  CHECK(out.mode == ums::EstimatorMode::kImuOnly);
  CHECK(std::abs(out.q_w_b.angularDistance(Eigen::Quaterniond::Identity())) < 1e-6);  // level, z up
  est.add_frame(*ff, &out, nullptr);  // same stamp again
  CHECK_FALSE(out.valid);
  CHECK(est.stats().frames == 1);
  CHECK(est.stats().frames_out_of_order == 1);
}
