// MapFramePoses (core/loop/map_frame_poses.hpp): the odometry until the frame is placed in the
// map, the map frame after, and a reset_counter that moves with the closer's corrections.
#include "core/loop/map_frame_poses.hpp"

#include <catch2/catch.hpp>
#include <random>
#include <vector>

#include "core/loop/loop_closer.hpp"

namespace ums::loop {
namespace {

struct Recorder final : PoseSink {
  std::vector<EstimatorOutput> frames;
  std::vector<NavState> imu;
  void on_frame_pose(const EstimatorOutput& out) override { frames.push_back(out); }
  void on_imu_pose(std::int64_t, const NavState& s) override { imu.push_back(s); }
};

Vocabulary tiny_vocabulary() {
  std::mt19937_64 rng(5);
  std::vector<std::vector<Descriptor>> images(6, std::vector<Descriptor>(30));
  for (auto& image : images)
    for (Descriptor& d : image)
      for (auto& w : d) w = rng();
  VocabularyParams p;
  p.k = 4;
  p.levels = 2;
  return Vocabulary::train(images, p);
}

RigCalibration pinhole_rig() {
  RigCalibration r;
  for (CameraCalibration& c : r.cam) {
    c.width = 752, c.height = 480, c.fx = c.fy = 460.0, c.cx = 376.0, c.cy = 240.0;
  }
  return r;
}

EstimatorOutput pose(std::uint32_t epoch, std::uint32_t reset_counter) {
  EstimatorOutput o;
  o.valid = true;
  o.odometry_epoch = epoch;
  o.reset_counter = reset_counter;
  o.p_w_b = Eigen::Vector3d(1.0, 2.0, 3.0);
  o.q_w_b = Eigen::Quaterniond(Eigen::AngleAxisd(0.3, Eigen::Vector3d::UnitZ()));
  o.v_w_b = Eigen::Vector3d(0.5, 0.0, 0.0);
  return o;
}

void keyframe(LoopCloser* closer, std::uint32_t epoch, FrameId id) {
  MarginalizedKeyframe k;
  k.id = id;
  k.t_ns = 1'000'000'000LL * (id + 1);
  k.gravity_aligned = true;
  k.odometry_epoch = epoch;
  closer->on_keyframe(k);
}

// A map frame that the test moves by hand.
struct FakeSource final : MapFrameSource {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  std::uint32_t n = 0;
  bool map_from_odometry(std::uint32_t, Eigen::Isometry3d* out) const override {
    *out = T;
    return true;
  }
  std::uint32_t corrections() const override { return n; }
};

}  // namespace

TEST_CASE("MapFramePoses: spread_s turns a correction into a ramp over that time, without a reset", "[loop]") {
  FakeSource source;
  Recorder next;
  MapFramePoses map(source, &next, 1.0);  // 1 s
  EstimatorOutput o = pose(0, 3);
  o.t_ns = 0;
  map.on_frame_pose(o);
  // A 0.5 m, 10 deg correction at t = 0.5 s.
  source.T.translation() = Eigen::Vector3d(0.5, 0.0, 0.0);
  source.T.linear() = Eigen::AngleAxisd(10.0 * M_PI / 180.0, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  source.n = 1;
  for (const std::int64_t t_ns : {500'000'000LL, 1'000'000'000LL, 1'500'000'000LL, 2'000'000'000LL}) {
    o.t_ns = t_ns;
    map.on_frame_pose(o);
  }
  const Eigen::Vector3d p_odom(1.0, 2.0, 3.0);
  // At the correction nothing moves yet, half-way at +0.5 s, all of it at +1 s and after.
  CHECK((next.frames[1].p_w_b - p_odom).norm() < 1e-12);
  const Eigen::Vector3d p_full = source.T * p_odom;
  const Eigen::Vector3d p_half = Eigen::Vector3d(0.25, 0.0, 0.0) +
      Eigen::AngleAxisd(5.0 * M_PI / 180.0, Eigen::Vector3d::UnitZ()) * p_odom;
  CHECK((next.frames[2].p_w_b - p_half).norm() < 1e-9);
  CHECK((next.frames[3].p_w_b - p_full).norm() < 1e-9);
  CHECK((next.frames[4].p_w_b - p_full).norm() < 1e-9);
  for (const EstimatorOutput& f : next.frames) CHECK(f.reset_counter == 3);  // spread: no reset
  // Without spreading the same correction is a step and a reset.
  FakeSource step_source;
  Recorder step_next;
  MapFramePoses step(step_source, &step_next);
  o.t_ns = 0;
  step.on_frame_pose(o);
  step_source.T = source.T;
  step_source.n = 1;
  o.t_ns = 500'000'000LL;
  step.on_frame_pose(o);
  CHECK((step_next.frames[1].p_w_b - p_full).norm() < 1e-9);
  CHECK(step_next.frames[1].reset_counter == 4);
}

TEST_CASE("MapFramePoses: odometry before the map exists, the map frame once placed, odometry for a new session",
          "[loop]") {
  const Vocabulary voc = tiny_vocabulary();
  LoopCloser closer(LoopOptions{}, pinhole_rig(), voc);
  Recorder next;
  MapFramePoses map(closer, &next);
  // No keyframe yet: the odometry, unchanged.
  map.on_frame_pose(pose(0, 1));
  REQUIRE(next.frames.size() == 1);
  CHECK(next.frames[0].p_w_b == Eigen::Vector3d(1.0, 2.0, 3.0));
  CHECK(next.frames[0].reset_counter == 1);
  // The first levelled keyframe defines the map: T_map_odom = identity, same pose, same counter.
  keyframe(&closer, 0, 0);
  map.on_frame_pose(pose(0, 1));
  NavState s;
  s.p_w_b = Eigen::Vector3d(4.0, 5.0, 6.0);
  map.on_imu_pose(7, s);
  CHECK((next.frames[1].p_w_b - Eigen::Vector3d(1.0, 2.0, 3.0)).norm() < 1e-12);
  CHECK(next.frames[1].reset_counter == 1);
  CHECK((next.imu[0].p_w_b - Eigen::Vector3d(4.0, 5.0, 6.0)).norm() < 1e-12);
  // A reset (epoch 1, counter 2) is not in the map until a loop places it: the odometry again,
  // with the estimator's own counter (the consumer resets on the change).
  keyframe(&closer, 1, 1);
  Eigen::Isometry3d T;
  CHECK_FALSE(closer.map_from_odometry(1, &T));
  map.on_frame_pose(pose(1, 2));
  CHECK(next.frames[2].reset_counter == 2);
  CHECK(next.frames[2].p_w_b == Eigen::Vector3d(1.0, 2.0, 3.0));
}

}  // namespace ums::loop
