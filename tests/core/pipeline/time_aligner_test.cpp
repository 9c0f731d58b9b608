// The camera-IMU offset in the pipeline: frames and IMU samples leave the TimeAligner in IMU-time
// order whatever the offset's sign, frames on the IMU clock, a held frame's pixels copied, and the
// limits counted; nothing allocates per sample or frame.
#include "core/pipeline/time_aligner.hpp"

#include <catch2/catch.hpp>

#include <cstdint>
#include <utility>
#include <vector>

#include "profiling/alloc_counter.hpp"

using namespace ums;

namespace {

constexpr std::int64_t kMs = 1'000'000;

// What leaves the aligner: (t_ns, is_frame, first left pixel), reserved up front.
struct Recorder final : MeasurementSink {
  struct Item {
    std::int64_t t_ns;
    bool frame;
    int pixel;
  };
  Recorder() { items.reserve(4096); }
  void on_imu(const ImuSample& s) override { items.push_back({s.t_ns, false, -1}); }
  void on_stereo(const StereoFrame& f) override { items.push_back({f.t_ns, true, f.left.valid() ? f.left.data[0] : -1}); }
  std::vector<Item> items;
};

// 1 s of a 200 Hz IMU and a 20 Hz camera whose clock is td early (t_cam = t_imu - td), pushed in
// the order a source delivers them: by their own stamps, IMU first on ties. Frame k's left image
// is filled with k, and the buffer is reused for the next frame (as a source's would be).
Recorder run(TimeAligner* aligner, std::int64_t td_ns) {
  Recorder out;
  std::vector<std::uint8_t> left(8 * 4), right(8 * 4);
  std::int64_t next_frame_t_imu = 10 * kMs;
  int k = 0;
  for (std::int64_t t = 0; t <= 1000 * kMs; t += 5 * kMs) {
    while (next_frame_t_imu - td_ns < t) {  // frames stamped before this sample
      std::fill(left.begin(), left.end(), static_cast<std::uint8_t>(k));
      StereoFrame f;
      f.t_ns = next_frame_t_imu - td_ns;
      f.left = ImageView{left.data(), 8, 4, 8};
      f.right = ImageView{right.data(), 8, 4, 8};
      aligner->on_stereo(f, &out);
      next_frame_t_imu += 50 * kMs;
      ++k;
    }
    ImuSample s;
    s.t_ns = t;
    aligner->on_imu(s, &out);
  }
  return out;
}

// Every frame after all samples up to its time and before all later ones; samples in order.
void check_order(const Recorder& r) {
  std::int64_t last_imu = -1;
  for (std::size_t i = 0; i < r.items.size(); ++i) {
    const Recorder::Item& it = r.items[i];
    if (!it.frame) {
      CHECK(it.t_ns > last_imu);
      last_imu = it.t_ns;
      continue;
    }
    CHECK(last_imu <= it.t_ns);  // no later sample went before the frame
    if (i + 1 < r.items.size() && !r.items[i + 1].frame) CHECK(r.items[i + 1].t_ns > it.t_ns);
  }
}

int frames(const Recorder& r) {
  int n = 0;
  for (const auto& it : r.items) n += it.frame;
  return n;
}

}  // namespace

TEST_CASE("TimeAligner: no offset passes everything through as it came", "[pipeline]") {
  TimeAligner aligner(0, 8, 4);
  const Recorder r = run(&aligner, 0);
  check_order(r);
  CHECK(frames(r) == 20);
  CHECK(r.items.size() == 20 + 201);
  CHECK(aligner.counters().frames_held == 0);
}

TEST_CASE("TimeAligner: a camera 12 ms early waits for the IMU, its frames keep their pixels", "[pipeline]") {
  TimeAligner aligner(12 * kMs, 8, 4);
  const Recorder r = run(&aligner, 12 * kMs);
  check_order(r);
  CHECK(frames(r) == 20);
  // 21 were pushed: the one stamped 998 ms (1010 ms on the IMU clock) still waits for the IMU.
  CHECK(aligner.counters().frames_held == 21);
  CHECK(aligner.counters().frames_unaligned == 0);
  int k = 0;
  for (const auto& it : r.items) {
    if (!it.frame) continue;
    CHECK(it.t_ns == 10 * kMs + 50 * kMs * k);  // on the IMU clock
    CHECK(it.pixel == k);                        // the copy, not the reused source buffer
    ++k;
  }
  // The end of the input lets the last one go (counted: the IMU never reached it).
  Recorder rest;
  aligner.flush(&rest);
  REQUIRE(rest.items.size() == 1);
  CHECK(rest.items[0].t_ns == 1010 * kMs);
  CHECK(aligner.counters().frames_unaligned == 1);
}

TEST_CASE("TimeAligner: a held frame goes on right after the sample at its own time", "[pipeline]") {
  TimeAligner aligner(10 * kMs, 8, 4);  // frames land on IMU stamps: 10, 60, 110 ms ...
  const Recorder r = run(&aligner, 10 * kMs);
  check_order(r);
  int checked = 0;
  for (std::size_t i = 1; i < r.items.size(); ++i) {
    if (!r.items[i].frame) continue;
    CHECK_FALSE(r.items[i - 1].frame);
    CHECK(r.items[i - 1].t_ns == r.items[i].t_ns);  // not one IMU period later
    ++checked;
  }
  CHECK(checked == 20);
}

TEST_CASE("TimeAligner: a camera 8 ms late gets the IMU held back by 8 ms", "[pipeline]") {
  TimeAligner aligner(-8 * kMs, 8, 4);
  const Recorder r = run(&aligner, -8 * kMs);
  check_order(r);
  CHECK(frames(r) == 20);
  // The samples of the last 8 ms (995 and 1000 ms) wait for a frame or for 8 ms more of IMU, or
  // for the end of the input.
  CHECK(r.items.size() == 20 + 201 - 2);
  CHECK(aligner.counters().imu_released_early == 0);
  Recorder rest;
  aligner.flush(&rest);
  REQUIRE(rest.items.size() == 2);
  CHECK(rest.items[1].t_ns == 1000 * kMs);
}

TEST_CASE("TimeAligner: an offset beyond a frame period is counted, nothing is lost", "[pipeline]") {
  TimeAligner aligner(70 * kMs, 8, 4);
  const Recorder r = run(&aligner, 70 * kMs);
  CHECK(frames(r) >= 19);
  CHECK(aligner.counters().frames_unaligned > 10);
  TimeAligner late(-400 * kMs, 8, 4);  // 80 samples held: more than 0.25 s at 1 kHz would not fit
  const Recorder r2 = run(&late, -400 * kMs);
  check_order(r2);
  CHECK(late.counters().imu_released_early == 0);
}

TEST_CASE("TimeAligner: holding frames and samples allocates nothing", "[pipeline]") {
  for (std::int64_t td : {12 * kMs, -8 * kMs}) {
    TimeAligner aligner(td, 8, 4);
    Recorder out;
    std::vector<std::uint8_t> img(32, 7);
    AllocScope scope;
    for (int i = 0; i < 200; ++i) {
      ImuSample s;
      s.t_ns = i * 5 * kMs;
      aligner.on_imu(s, &out);
      if (i % 10 == 5) {
        StereoFrame f;
        f.t_ns = s.t_ns - td;
        f.left = f.right = ImageView{img.data(), 8, 4, 8};
        aligner.on_stereo(f, &out);
      }
    }
    CHECK(scope.allocations() == 0);
  }
}

namespace {

// Stands in for the pipeline with estimate_td: every frame it is handed moves the offset for the
// next ones to the following value of a schedule (the estimator's refinement).
struct Follower final : MeasurementSink {
  Follower(TimeAligner* a, std::vector<std::int64_t> schedule_ns) : aligner(a), schedule(std::move(schedule_ns)) {
    rec.items.reserve(4096);
  }
  void on_imu(const ImuSample& s) override { rec.on_imu(s); }
  void on_stereo(const StereoFrame& f) override {
    rec.on_stereo(f);
    cam_t_ns.push_back(f.t_ns - f.td_ns);
    td_ns.push_back(f.td_ns);
    if (k < schedule.size()) aligner->set_td_ns(schedule[k++]);
  }
  TimeAligner* aligner;
  std::vector<std::int64_t> schedule;
  std::size_t k = 0;
  Recorder rec;
  std::vector<std::int64_t> cam_t_ns, td_ns;
};

}  // namespace

TEST_CASE("TimeAligner: a refined offset restamps the next frames, across zero, IMU-time order kept", "[pipeline]") {
  // The calibration says 0 and allows 10 ms; the true offset is +6 ms (camera 6 ms early). The
  // estimate walks 0 -> -4 -> +6 ms and asks for 30 ms once (clamped).
  TimeAligner aligner(0, 8, 4, 10 * kMs);
  Follower out(&aligner, {-2 * kMs, -4 * kMs, 30 * kMs, 6 * kMs});
  std::vector<std::uint8_t> left(8 * 4, 1), right(8 * 4, 1);
  std::int64_t next_cam = 4 * kMs;  // camera stamps 4, 54, 104 ... (IMU time 10, 60, 110 ...)
  for (std::int64_t t = 0; t <= 500 * kMs; t += 5 * kMs) {
    while (next_cam < t) {
      StereoFrame f;
      f.t_ns = next_cam;
      f.left = ImageView{left.data(), 8, 4, 8};
      f.right = ImageView{right.data(), 8, 4, 8};
      aligner.on_stereo(f, &out);
      next_cam += 50 * kMs;
    }
    ImuSample s;
    s.t_ns = t;
    aligner.on_imu(s, &out);
  }
  aligner.flush(&out);
  check_order(out.rec);
  REQUIRE(out.td_ns.size() == 10);
  // Each frame carries the offset set after the one before it, 30 ms clamped to the 10 ms range.
  const std::int64_t expect[] = {0, -2 * kMs, -4 * kMs, 10 * kMs, 6 * kMs, 6 * kMs};
  for (int i = 0; i < 6; ++i) CHECK(out.td_ns[i] == expect[i]);
  for (std::size_t i = 0; i < out.cam_t_ns.size(); ++i) CHECK(out.cam_t_ns[i] == 4 * kMs + 50 * kMs * static_cast<std::int64_t>(i));
  CHECK(aligner.td_ns() == 6 * kMs);
  CHECK(aligner.counters().frames_held >= 6);  // the positive offsets wait for the IMU
  CHECK(aligner.counters().frames_restamped == 0);
}

TEST_CASE("TimeAligner: a frame whose offset fell below a sample already let go goes on at that sample",
          "[pipeline]") {
  TimeAligner aligner(0, 8, 4, 10 * kMs);
  Recorder out;
  aligner.set_td_ns(-2 * kMs);
  for (std::int64_t t = 0; t <= 20 * kMs; t += 5 * kMs) {
    ImuSample s;
    s.t_ns = t;
    aligner.on_imu(s, &out);  // held by 2 ms: 0 .. 15 ms go on
  }
  REQUIRE(out.items.size() == 4);
  aligner.set_td_ns(-8 * kMs);
  std::vector<std::uint8_t> img(32, 3);
  StereoFrame f;
  f.t_ns = 22 * kMs;  // 14 ms on the IMU clock: the 15 ms sample has gone on already
  f.left = f.right = ImageView{img.data(), 8, 4, 8};
  aligner.on_stereo(f, &out);
  aligner.flush(&out);
  check_order(out);
  REQUIRE(out.items.size() == 6);
  CHECK(out.items[4].frame);
  CHECK(out.items[4].t_ns == 15 * kMs);  // 1 ms later than asked, never before a sample
  CHECK(aligner.counters().frames_restamped == 1);
}

TEST_CASE("TimeAligner: a refined offset allocates nothing per frame", "[pipeline]") {
  TimeAligner aligner(0, 8, 4, 10 * kMs);
  Recorder out;
  std::vector<std::uint8_t> img(32, 7);
  AllocScope scope;
  for (int i = 0; i < 200; ++i) {
    ImuSample s;
    s.t_ns = i * 5 * kMs;
    aligner.on_imu(s, &out);
    if (i % 10 == 5) {
      aligner.set_td_ns((i % 20 == 5 ? -7 : 7) * kMs);
      StereoFrame f;
      f.t_ns = s.t_ns;
      f.left = f.right = ImageView{img.data(), 8, 4, 8};
      aligner.on_stereo(f, &out);
    }
  }
  CHECK(scope.allocations() == 0);
}
