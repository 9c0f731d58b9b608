// Sensor faults on a stream: each kind does exactly what it says to the measurements in its
// interval and nothing outside it, counts what it did, and the spec parser names what is wrong.
#include "hal/replay/fault_injection.hpp"

#include <catch2/catch.hpp>

#include <cmath>
#include <cstdint>
#include <string>
#include <vector>

#include "profiling/alloc_counter.hpp"

using namespace ums;
using namespace ums::hal;

namespace {

constexpr std::int64_t kMs = 1'000'000;

struct Item {
  std::int64_t t_ns;
  bool frame;
  int left_pixel;   // frames: the first left pixel, -1 without a left image
  bool right;       // frames: a right image
  bool finite;      // IMU: all values finite
  double gyro_x;
};

struct Recorder final : MeasurementSink {
  Recorder() { items.reserve(8192); }
  void on_imu(const ImuSample& s) override {
    items.push_back({s.t_ns, false, -1, false, s.gyro_rad_s.allFinite() && s.accel_m_s2.allFinite(), s.gyro_rad_s.x()});
  }
  void on_stereo(const StereoFrame& f) override {
    items.push_back({f.t_ns, true, f.left.valid() ? f.left.data[0] : -1, f.right.valid(), true, 0.0});
  }
  std::vector<Item> items;
};

// 4 s of a 200 Hz IMU and a 20 Hz camera from t = 1 s; frame k's pixels are all k + 1.
Recorder run(const std::vector<std::string>& specs, std::uint64_t seed = 1) {
  std::vector<Fault> faults(specs.size());
  for (std::size_t i = 0; i < specs.size(); ++i) {
    std::string error;
    REQUIRE(parse_fault(specs[i], &faults[i], &error));
  }
  Recorder out;
  FaultInjector inject(faults.data(), static_cast<int>(faults.size()), seed, &out);
  std::vector<std::uint8_t> left(16 * 8), right(16 * 8);
  int k = 0;
  for (std::int64_t t = 1000 * kMs; t <= 5000 * kMs; t += 5 * kMs) {
    ImuSample s;
    s.t_ns = t;
    s.gyro_rad_s.x() = static_cast<double>(t / kMs);
    inject.on_imu(s);
    if ((t - 1000 * kMs) % (50 * kMs) == 0) {
      std::fill(left.begin(), left.end(), static_cast<std::uint8_t>(k + 1));
      std::fill(right.begin(), right.end(), static_cast<std::uint8_t>(k + 1));
      StereoFrame f;
      f.t_ns = t;
      f.left = ImageView{left.data(), 16, 8, 16};
      f.right = ImageView{right.data(), 16, 8, 16};
      inject.on_stereo(f);
      ++k;
    }
  }
  inject.flush();
  return out;
}

int count(const Recorder& r, bool frames, std::int64_t from_ns, std::int64_t to_ns) {
  int n = 0;
  for (const Item& it : r.items) n += it.frame == frames && it.t_ns >= from_ns && it.t_ns < to_ns;
  return n;
}

}  // namespace

TEST_CASE("faults: no fault passes every measurement on unchanged", "[replay][faults]") {
  const Recorder r = run({});
  CHECK(count(r, false, 0, INT64_MAX) == 801);
  CHECK(count(r, true, 0, INT64_MAX) == 81);
}

TEST_CASE("faults: an IMU gap loses exactly the samples of its interval", "[replay][faults]") {
  const Recorder r = run({"imu-gap:1:0.5"});  // 2.0 .. 2.5 s
  CHECK(count(r, false, 2000 * kMs, 2500 * kMs) == 0);
  CHECK(count(r, false, 0, INT64_MAX) == 801 - 100);
  CHECK(count(r, true, 0, INT64_MAX) == 81);
}

TEST_CASE("faults: NaN and huge IMU values stay in their interval", "[replay][faults]") {
  const Recorder r = run({"imu-nan:1:0.1", "imu-huge:2:0.05"});
  int nan = 0, huge = 0;
  for (const Item& it : r.items) {
    if (it.frame) continue;
    if (!it.finite) {
      ++nan;
      CHECK((it.t_ns >= 2000 * kMs && it.t_ns < 2100 * kMs));
    } else if (it.gyro_x == 1e9) {
      ++huge;
      CHECK((it.t_ns >= 3000 * kMs && it.t_ns < 3050 * kMs));
    }
  }
  CHECK(nan == 20);
  CHECK(huge == 10);
}

TEST_CASE("faults: duplicated and swapped IMU samples", "[replay][faults]") {
  const Recorder dup = run({"imu-dup:1:0.1"});
  CHECK(count(dup, false, 0, INT64_MAX) == 801 + 20);
  const Recorder swap = run({"imu-swap:1:0.1"});
  CHECK(count(swap, false, 0, INT64_MAX) == 801);
  int backwards = 0;
  std::int64_t last = -1;
  for (const Item& it : swap.items) {
    if (it.frame) continue;
    backwards += it.t_ns < last;
    last = it.t_ns;
  }
  CHECK(backwards == 10);  // 20 samples in 10 swapped pairs
}

TEST_CASE("faults: frame gap, random drops (seeded), duplicates and the end of the images", "[replay][faults]") {
  CHECK(count(run({"frame-gap:1:1"}), true, 2000 * kMs, 3000 * kMs) == 0);
  const Recorder drop = run({"frame-drop:0:10:0.1"});
  const int kept = count(drop, true, 0, INT64_MAX);
  CHECK(kept >= 81 - 18);  // 10 % of 81: 8 expected
  CHECK(kept <= 81 - 2);
  CHECK(count(run({"frame-drop:0:10:0.1"}), true, 0, INT64_MAX) == kept);  // the same seed, the same frames
  CHECK(count(run({"frame-dup:1:0.5"}), true, 0, INT64_MAX) == 81 + 10);
  const Recorder end = run({"images-end:2"});
  CHECK(count(end, true, 3000 * kMs, INT64_MAX) == 0);
  CHECK(count(end, false, 3000 * kMs, INT64_MAX) == 401);  // the IMU goes on
}

TEST_CASE("faults: a frozen camera repeats the last image before the fault, blackout and a lost right camera",
          "[replay][faults]") {
  const Recorder r = run({"frame-freeze:1:0.5", "blackout:3:0.2", "right-lost:2:0.1"});
  for (const Item& it : r.items) {
    if (!it.frame) continue;
    const int k = static_cast<int>((it.t_ns - 1000 * kMs) / (50 * kMs));
    if (it.t_ns >= 2000 * kMs && it.t_ns < 2500 * kMs) CHECK(it.left_pixel == 20);  // frame 19's, at 1.95 s
    else if (it.t_ns >= 4000 * kMs && it.t_ns < 4200 * kMs) CHECK(it.left_pixel == 0);
    else CHECK(it.left_pixel == k + 1);
    CHECK(it.right == !(it.t_ns >= 3000 * kMs && it.t_ns < 3100 * kMs));
  }
}

TEST_CASE("faults: a clock jump moves every stamp in its interval, then back", "[replay][faults]") {
  const Recorder r = run({"clock-jump:1:1:0.5"});
  int moved = 0;
  for (const Item& it : r.items) moved += it.t_ns >= 2500 * kMs && it.t_ns < 3500 * kMs && !it.frame;
  CHECK(moved == 200 + 100);  // the jumped second, plus the real 2.5-3.0 s
  CHECK(count(r, false, 0, INT64_MAX) == 801);
}

TEST_CASE("faults: the spec parser names the part that is wrong", "[replay][faults]") {
  Fault f;
  std::string error;
  CHECK(parse_fault("imu-gap:20:0.5", &f, &error));
  CHECK(f.kind == FaultKind::kImuGap);
  CHECK(f.start_s == 20.0);
  CHECK(f.duration_s == 0.5);
  CHECK_FALSE(parse_fault("imu-hole:20:0.5", &f, &error));
  CHECK(error.find("unknown kind 'imu-hole'") != std::string::npos);
  CHECK_FALSE(parse_fault("imu-gap:x:0.5", &f, &error));
  CHECK(error.find("start 'x'") != std::string::npos);
  CHECK_FALSE(parse_fault("imu-gap:20", &f, &error));
  CHECK(error.find("duration > 0") != std::string::npos);
  CHECK_FALSE(parse_fault("frame-drop:0:10:1.5", &f, &error));
  CHECK_FALSE(parse_fault("clock-jump:10:0", &f, &error));
  CHECK(parse_fault("images-end:40", &f, &error));
  CHECK_FALSE(parse_fault("imu-gap:20:nan", &f, &error));
}

TEST_CASE("faults: injecting allocates nothing per measurement", "[replay][faults]") {
  Fault faults[2];
  std::string error;
  REQUIRE(parse_fault("frame-freeze:0.1:0.2", &faults[0], &error));
  REQUIRE(parse_fault("blackout:0.4:0.2", &faults[1], &error));
  Recorder out;
  FaultInjector inject(faults, 2, 1, &out);
  std::vector<std::uint8_t> img(16 * 8, 5);
  AllocScope scope;
  for (int i = 0; i < 200; ++i) {
    ImuSample s;
    s.t_ns = i * 5 * kMs;
    inject.on_imu(s);
    if (i % 10 == 0) {
      StereoFrame f;
      f.t_ns = s.t_ns;
      f.left = f.right = ImageView{img.data(), 16, 8, 16};
      inject.on_stereo(f);
    }
  }
  CHECK(scope.allocations() == 0);
}
