// Map files of the loop closer (core/loop/loop_map.cpp): a round trip, and every malformed file
// refused with its reason, leaving the closer as it was (it then loads a good map).
#include <catch2/catch.hpp>
#include <cstring>
#include <random>
#include <stdexcept>
#include <vector>

#include "core/loop/loop_closer.hpp"

namespace ums::loop {
namespace {

RigCalibration rig(double fx_px) {
  RigCalibration r;
  for (CameraCalibration& c : r.cam) {
    c.width = 752;
    c.height = 480;
    c.fx = c.fy = fx_px;
    c.cx = 376.0;
    c.cy = 240.0;
  }
  r.cam[1].T_b_c.translation().x() = 0.11;
  return r;
}

Vocabulary small_vocabulary() {
  std::mt19937_64 rng(3);
  std::vector<std::vector<Descriptor>> images(8, std::vector<Descriptor>(40));
  for (auto& image : images)
    for (Descriptor& d : image)
      for (auto& w : d) w = rng();
  VocabularyParams p;
  p.k = 4;
  p.levels = 2;
  return Vocabulary::train(images, p);
}

// Keyframes along a line, levelled, without images (the map keeps their poses; no features).
void feed(LoopCloser* closer, int n) {
  MarginalizedKeyframe k;
  k.gravity_aligned = true;
  for (int i = 0; i < n; ++i) {
    k.id = static_cast<FrameId>(i);
    k.t_ns = 1'000'000'000LL * (i + 1);
    k.T_odom_b.setIdentity();
    k.T_odom_b.translation() = Eigen::Vector3d(0.3 * i, 0.1, 1.0);
    closer->on_keyframe(k);
  }
}

std::vector<std::uint8_t> with_crc(std::vector<std::uint8_t> b) {
  const std::uint32_t crc = crc32(b.data(), b.size() - 4);
  std::memcpy(b.data() + b.size() - 4, &crc, 4);
  return b;
}

void expect_refused(LoopCloser* closer, const std::vector<std::uint8_t>& bytes, const std::string& reason) {
  try {
    closer->load_map(bytes, "test.map");
    FAIL("accepted a malformed map (" << reason << ")");
  } catch (const std::runtime_error& e) {
    INFO(e.what());
    CHECK(std::string(e.what()).find("test.map: not a usable map: " + reason) != std::string::npos);
  }
  CHECK(closer->database().size() == 0);
  CHECK(closer->loaded_keyframes() == 0);
}

}  // namespace

TEST_CASE("LoopCloser map: saved keyframes load back with their poses, in order", "[loop]") {
  const Vocabulary voc = small_vocabulary();
  LoopCloser a(LoopOptions{}, rig(460.0), voc);
  feed(&a, 12);
  const std::vector<std::uint8_t> bytes = a.save_map();
  LoopCloser b(LoopOptions{}, rig(460.0), voc);
  b.load_map(bytes, "test.map");
  REQUIRE(b.loaded_keyframes() == 12);
  REQUIRE(b.database().size() == 12);
  int i = 0;
  for (std::int32_t s = b.database().oldest(); s >= 0; s = b.database().at(s).next, ++i) {
    const KeyframeRecord& r = b.database().at(static_cast<std::uint32_t>(s));
    CHECK(r.id == static_cast<FrameId>(i));
    CHECK((r.T_map_b.translation() - Eigen::Vector3d(0.3 * i, 0.1, 1.0)).norm() < 1e-12);
  }
  // The run's own odometry has no map pose until a loop places it.
  feed(&b, 1);
  Eigen::Isometry3d T;
  CHECK_FALSE(b.map_from_odometry(0, &T));
  CHECK(b.stats().sessions == 2);
}

TEST_CASE("LoopCloser map: malformed files are refused with the reason and change nothing", "[loop]") {
  const Vocabulary voc = small_vocabulary();
  LoopCloser a(LoopOptions{}, rig(460.0), voc);
  feed(&a, 6);
  const std::vector<std::uint8_t> good = a.save_map();
  LoopCloser b(LoopOptions{}, rig(460.0), voc);

  expect_refused(&b, std::vector<std::uint8_t>(good.begin(), good.begin() + 20), "truncated");
  std::vector<std::uint8_t> bad = good;
  bad[40] ^= 0x10;
  expect_refused(&b, bad, "CRC mismatch");
  bad = good;
  bad[8] = 2;  // version
  expect_refused(&b, with_crc(bad), "version 2");
  bad = good;
  bad[20] = 0xff, bad[21] = 0xff;  // keyframe count (byte 20) 65535+
  expect_refused(&b, with_crc(bad), "65535 keyframes, capacity 2000");
  bad = good;
  bad[20] += 1;  // one keyframe more than the file holds
  expect_refused(&b, with_crc(bad), "truncated in keyframe 6");
  bad = good;
  const double nan = std::nan("");
  std::memcpy(bad.data() + 28 + 4 + 8 + 4, &nan, 8);  // the first keyframe's x (after a 28-byte header, id, t_ns, session)
  expect_refused(&b, with_crc(bad), "keyframe 0: pose not a rigid transform");
  bad = good;
  bad.insert(bad.end() - 4, 3, 0);
  expect_refused(&b, with_crc(bad), "3 bytes after the last record");

  LoopCloser other_camera(LoopOptions{}, rig(470.0), voc);
  expect_refused(&other_camera, good, "made with another camera calibration");
  // Nothing changed: the good file loads into the closer that refused the others.
  b.load_map(good, "test.map");
  CHECK(b.loaded_keyframes() == 6);
  // Only a fresh closer loads a map.
  CHECK_THROWS_WITH(a.load_map(good, "test.map"),
                    Catch::Contains("test.map: not a usable map: a map loads into a closer that has seen no keyframe"));
  CHECK(a.database().size() == 6);
}

}  // namespace ums::loop
