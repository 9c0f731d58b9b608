#include "core/estimator/estimator.hpp"

#include <cmath>
#include <limits>
#include <memory>

#include <catch2/catch.hpp>

#include "core/frontend/frontend.hpp"
#include "core/imu/saturation.hpp"
#include "hal/replay/euroc_reader.hpp"
#include "profiling/alloc_counter.hpp"
#include "tests/common/test_paths.hpp"

namespace {

// Keeps what the keyframe outlet hands on (outside the frame path of a product: a test).
struct RecordingKeyframeSink final : ums::KeyframeSink {
  struct Kept {
    ums::FrameId id;
    std::int64_t t_ns;
    Eigen::Isometry3d T_odom_b;
    int observations, points, stereo;
    double max_point_range_m;
  };
  std::vector<Kept> kept;
  void on_keyframe(const ums::MarginalizedKeyframe& k) override {
    Kept c{k.id, k.t_ns, k.T_odom_b, static_cast<int>(k.observations.size()), 0, 0, 0.0};
    for (const ums::KeyframeObservation& o : k.observations) {
      c.points += o.has_point ? 1 : 0;
      c.stereo += o.stereo ? 1 : 0;
      if (o.has_point) c.max_point_range_m = std::max(c.max_point_range_m, (o.p_odom - k.T_odom_b.translation()).norm());
    }
    kept.push_back(c);
  }
};

struct MicroRun {
  std::vector<ums::EstimatorOutput> outputs;
  ums::EstimatorStats stats;
  std::uint64_t steady_allocations = 0;
  RecordingKeyframeSink keyframes;
};

// The real EuRoC micro sequence (V1_01, the vehicle standing on the floor) through the front end
// and the estimator, as the replay pipeline does (without its gyro hint: nothing moves).
MicroRun run_micro(const ums::EstimatorOptions& options = ums::EstimatorOptions()) {
  ums::hal::EurocReader reader;
  reader.open(ums::test::euroc_micro_dir(), ums::hal::EurocReaderOptions());
  const ums::RigCalibration rig = reader.calibration();
  ums::FrontendOptions fo;
  auto frontend = std::make_unique<ums::Frontend>(fo, rig);
  ums::EstimatorOptions eo = options;
  eo.focal_px = rig.cam[0].fx;
  auto estimator = std::make_unique<ums::Estimator>(eo, rig);
  auto features = std::make_unique<ums::FrameFeatures>();
  ums::SaturationElement saturation;
  MicroRun run;
  run.outputs.reserve(200);
  run.keyframes.kept.reserve(200);
  estimator->set_keyframe_sink(&run.keyframes);
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

TEST_CASE("estimator: skipping the stage comparison for a few 2D-left landmarks keeps every pose", "[estimator][slow]") {
  // The comparison restores the window and solves 3D + 2D-left from the same start when the two
  // stages agree, so skipping it gives the same poses to the bit wherever it would have agreed.
  // Round 2 without its wall-time bound, as replay --deterministic runs it: under qemu the bound
  // cuts it at different iterations in two runs.
  ums::EstimatorOptions always;
  always.round2_time_s = std::numeric_limits<double>::infinity();
  always.stage_min_2d_left = 0;  // the paper: compare whenever a 2D-left landmark exists
  const MicroRun paper = run_micro(always);
  REQUIRE(paper.stats.stage_kept_2d_left > 0);
  REQUIRE(paper.stats.stage_added_2d_right == 0);
  ums::EstimatorOptions o;
  o.round2_time_s = std::numeric_limits<double>::infinity();
  o.stage_min_2d_left = 1000;
  const MicroRun skipped = run_micro(o);
  CHECK(skipped.stats.stage_kept_2d_left == 0);
  CHECK(skipped.stats.stage_few_2d_left == paper.stats.stage_kept_2d_left);
  REQUIRE(skipped.outputs.size() == paper.outputs.size());
  for (std::size_t k = 0; k < paper.outputs.size(); ++k) {
    CHECK(skipped.outputs[k].p_w_b == paper.outputs[k].p_w_b);
    CHECK(skipped.outputs[k].q_w_b.coeffs() == paper.outputs[k].q_w_b.coeffs());
  }
  CHECK(skipped.steady_allocations == 0);
}

TEST_CASE("estimator: landmarks spread over the view still hold the rig at rest, allocating nothing", "[estimator][slow]") {
  ums::EstimatorOptions o;
  o.landmark_spread_px = 80.0;
  const MicroRun run = run_micro(o);
  REQUIRE(run.stats.initialized);
  double max_drift_m = 0.0;
  for (const ums::EstimatorOutput& out : run.outputs) {
    if (out.valid) max_drift_m = std::max(max_drift_m, (out.p_w_b - run.outputs.front().p_w_b).norm());
  }
  CHECK(max_drift_m <= 0.02);
  CHECK(run.steady_allocations == 0);
}

TEST_CASE("estimator: every keyframe leaving the window reaches the keyframe outlet with its points", "[estimator][slow]") {
  const MicroRun run = run_micro();
  const auto& kept = run.keyframes.kept;
  INFO(kept.size() << " keyframes emitted, " << run.stats.marginalized_old << " marginalized as the oldest");
  REQUIRE(kept.size() >= 3);
  CHECK(kept.size() <= run.stats.marginalized_old);  // only frames that leave as the oldest (not in IMU_ONLY)
  CHECK(run.stats.keyframes_emitted == kept.size());
  const Eigen::Vector3d p0 = run.outputs.front().p_w_b;
  for (std::size_t i = 0; i < kept.size(); ++i) {
    if (i > 0) CHECK(kept[i].id > kept[i - 1].id);  // FrameIds grow: never reused
    if (i > 0) CHECK(kept[i].t_ns > kept[i - 1].t_ns);
    CHECK(kept[i].observations >= 50);                // a textured room: ~200 features per frame
    CHECK(kept[i].points >= kept[i].observations / 2);
    CHECK(kept[i].stereo >= 50);
    CHECK(kept[i].max_point_range_m < 60.0);          // within the landmark depth range
    CHECK((kept[i].T_odom_b.translation() - p0).norm() < 0.02);  // at rest: where the rig stands
  }
  // Each keyframe's id names the frame the output named at its time.
  for (const auto& k : kept) {
    bool found = false;
    for (const ums::EstimatorOutput& o : run.outputs) found = found || (o.frame_id == k.id && o.t_ns == k.t_ns);
    CHECK(found);
  }
}

TEST_CASE("estimator: invalid options are refused at start-up", "[estimator]") {
  ums::RigCalibration rig;
  ums::EstimatorOptions o;
  o.window_size = 100;  // above capacity::kWindowSize
  CHECK_THROWS_AS(ums::Estimator(o, rig), std::invalid_argument);
  o = ums::EstimatorOptions();
  o.sigma_px = 0.0;
  CHECK_THROWS_AS(ums::Estimator(o, rig), std::invalid_argument);
  o = ums::EstimatorOptions();
  o.predicted_stop_share = 1.5;  // a share of the function tolerance
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
