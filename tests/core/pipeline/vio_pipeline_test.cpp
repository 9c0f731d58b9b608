// The core pipeline on the real EuRoC micro sequence (V1_01, the vehicle standing on the floor):
// what arrives at the pose and keyframe-image outlets, the allocation budget, and the one place
// the camera-IMU offset td_s is applied.

#include "core/pipeline/vio_pipeline.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <initializer_list>
#include <limits>
#include <memory>
#include <stdexcept>
#include <vector>

#include <catch2/catch.hpp>

#include "core/imu/imu_noise.hpp"
#include "hal/replay/euroc_reader.hpp"
#include "profiling/alloc_counter.hpp"
#include "tests/common/test_paths.hpp"

namespace {

constexpr std::size_t kReserve = 4096;  // more than the micro sequence delivers: no growth

struct FramePose {
  std::int64_t t_ns = 0;
  ums::FrameId id = ums::kNoFrame;
  bool keyframe = false;
};

struct KeyframeImage {
  ums::FrameId id = ums::kNoFrame;
  std::int64_t t_ns = 0;
  ums::ImageView left;
  std::uint64_t pixel_sum = 0;  // of the view, taken during the call (the view is only valid then)
  int n_features = 0;  // features handed on with the image
};

std::uint64_t pixel_sum(const ums::ImageView& v) {
  std::uint64_t s = 0;
  for (int y = 0; y < v.height; ++y)
    for (int x = 0; x < v.width; ++x) s += v.row(y)[x];
  return s;
}

// Records what the pipeline hands on; reserved up front so that recording never allocates.
class Recorder final : public ums::PoseSink, public ums::KeyframeImageSink {
 public:
  Recorder() {
    frame_poses.reserve(kReserve);
    imu_pose_t_ns.reserve(16 * kReserve);
    keyframes.reserve(kReserve);
  }
  void on_frame_pose(const ums::EstimatorOutput& out) override {
    CHECK(out.valid);
    frame_poses.push_back({out.t_ns, out.frame_id, out.keyframe});
  }
  void on_imu_pose(std::int64_t t_ns, const ums::NavState&) override { imu_pose_t_ns.push_back(t_ns); }
  void on_keyframe_image(ums::FrameId id, std::int64_t t_ns, const ums::ImageView& left,
                         const ums::FrameFeatures& features) override {
    keyframes.push_back({id, t_ns, left, pixel_sum(left), static_cast<int>(features.features.size())});
  }

  std::vector<FramePose> frame_poses;
  std::vector<std::int64_t> imu_pose_t_ns;
  std::vector<KeyframeImage> keyframes;
};

// The pipeline's record of every frame, in the order they were processed.
struct RecordObserver final : ums::FrameObserver {
  void on_frame_done(const ums::VioFrameRecord& r, const ums::StereoFrame&) override {
    records->push_back(r);
    if (r.estimated && r.estimate.valid) ++*estimated_valid;
  }
  std::vector<ums::VioFrameRecord>* records;
  std::uint64_t* estimated_valid;
};

// What the test saw going in and coming out, frame by frame.
struct Run {
  Recorder out;
  std::vector<std::int64_t> frame_t_ns;       // source stamps
  std::vector<std::uint64_t> left_sum;         // pixel sum of the left view pushed with each frame
  std::vector<std::int64_t> imu_t_ns;
  std::vector<ums::VioFrameRecord> records;
  ums::VioPipelineCounters counters;
  std::uint64_t steady_allocations = 0;
  std::uint64_t estimated_valid = 0;           // frames whose record says: a pose exists
};

std::unique_ptr<ums::VioPipeline> make_pipeline(const ums::RigCalibration& rig, bool frontend_only) {
  ums::VioPipelineOptions po;
  po.frontend_only = frontend_only;
  ums::EstimatorOptions eo;
  eo.focal_px = rig.cam[0].fx;
  eo.keyframe.focal_px = static_cast<float>(eo.focal_px);
  eo.preintegration.noise = ums::ImuNoise::from_calibration(rig.imu);
  // The second round bounded by its iterations, not by the wall clock (as `replay --deterministic`):
  // under a loaded qemu-arm its 10 ms cut the inline and the executor runs differently.
  eo.round2_time_s = std::numeric_limits<double>::infinity();
  return std::make_unique<ums::VioPipeline>(po, ums::FrontendOptions(), eo, rig);
}

void push(ums::hal::EurocReader::Event ev, const ums::ImuSample& imu, const ums::StereoFrame& frame,
          ums::VioPipeline* pipeline, Run* run) {
  if (ev == ums::hal::EurocReader::Event::kImu) {
    run->imu_t_ns.push_back(imu.t_ns);
    pipeline->on_imu(imu);
    return;
  }
  run->frame_t_ns.push_back(frame.t_ns);
  run->left_sum.push_back(pixel_sum(frame.left));
  pipeline->on_stereo(frame);
}

// IMU samples [first, first + count) of the recording replaced by `value` on every axis.
struct ImuCorruption {
  std::size_t first = SIZE_MAX;
  std::size_t count = 0;
  double value = 0.0;
};

void corrupt(std::initializer_list<ImuCorruption> corruptions, std::size_t index, ums::ImuSample* imu) {
  for (const ImuCorruption& c : corruptions) {
    if (index < c.first || index - c.first >= c.count) continue;
    imu->gyro_rad_s.setConstant(c.value);
    imu->accel_m_s2.setConstant(c.value);
  }
}

// The micro sequence through a VioPipeline (rig td_s set to td_s); allocations counted from the
// 50th frame on.
Run run_micro(double td_s, bool frontend_only = false, std::initializer_list<ImuCorruption> corruption = {},
              ums::BackendExecutor* executor = nullptr) {
  ums::hal::EurocReader reader;
  reader.open(ums::test::euroc_micro_dir(), ums::hal::EurocReaderOptions());
  ums::RigCalibration rig = reader.calibration();
  rig.td_s = td_s;
  auto pipeline = make_pipeline(rig, frontend_only);
  Run run;
  pipeline->set_pose_sink(&run.out);
  pipeline->set_keyframe_image_sink(&run.out);
  RecordObserver observer;
  observer.records = &run.records;
  observer.estimated_valid = &run.estimated_valid;
  pipeline->set_frame_observer(&observer);
  pipeline->set_backend_executor(executor);
  for (auto* v : {&run.frame_t_ns, &run.imu_t_ns}) v->reserve(16 * kReserve);
  run.left_sum.reserve(kReserve);
  run.records.reserve(kReserve);
  ums::ImuSample imu;
  ums::StereoFrame frame;
  for (;;) {
    const auto ev = reader.next(&imu, &frame);
    if (ev == ums::hal::EurocReader::Event::kEnd) break;
    if (ev == ums::hal::EurocReader::Event::kImu) corrupt(corruption, run.imu_t_ns.size(), &imu);
    const bool steady = pipeline->counters().frames >= 50;
    ums::AllocScope scope;
    push(ev, imu, frame, pipeline.get(), &run);
    if (steady) run.steady_allocations += scope.allocations();
  }
  pipeline->flush();  // the end of the recording: nothing stays held for the camera-IMU offset
  run.counters = pipeline->counters();
  return run;
}

// Runs the back end's tasks later, on the calling thread: all of them at wait_idle(), or when
// capacity::kBackendTasks wait. A frame's back end then runs after the next pair was read, whose
// pixels the reader writes over the previous pair's: what the pipeline hands a task must be its own.
class DeferredExecutor final : public ums::BackendExecutor {
 public:
  void submit(Task task, void* context, std::uint32_t arg) override {
    if (waiting_ == ums::capacity::kBackendTasks) wait_idle();
    queue_[waiting_++] = Entry{task, context, arg};
    if (waiting_ > deepest) deepest = waiting_;
  }
  void wait_idle() override {
    for (std::size_t i = 0; i < waiting_; ++i) queue_[i].task(queue_[i].context, queue_[i].arg);
    waiting_ = 0;
  }
  std::size_t deepest = 0;  // the most tasks that waited at once

 private:
  struct Entry {
    Task task = nullptr;
    void* context = nullptr;
    std::uint32_t arg = 0;
  };
  Entry queue_[ums::capacity::kBackendTasks];
  std::size_t waiting_ = 0;
};

// How many elements of two equally long sequences differ by `differs`.
template <class Seq, class Differs>
int mismatches(const Seq& a, const Seq& b, Differs differs) {
  int n = 0;
  for (std::size_t i = 0; i < a.size(); ++i) n += differs(a[i], b[i]) ? 1 : 0;
  return n;
}

}  // namespace

TEST_CASE("pipeline on the EuRoC micro sequence: a pose per frame with one, keyframe images, 0 allocations",
          "[pipeline]") {
  const Run run = run_micro(0.0);
  REQUIRE(run.frame_t_ns.size() == 95);
  CHECK(run.counters.frames == 95);
  CHECK(run.counters.imu_samples == run.imu_t_ns.size());
  CHECK(run.counters.frontend_rejected_frames == 0);
  // Every frame with a valid estimate reached the pose sink, in order, at its own stamp (td 0).
  REQUIRE(run.out.frame_poses.size() == run.estimated_valid);
  CHECK(run.out.frame_poses.size() >= 80);  // at rest: initialized within the first second
  std::size_t k = 0;
  for (std::size_t i = 0; i < run.records.size(); ++i) {
    CHECK(run.records[i].t_ns == run.frame_t_ns[i]);
    if (!run.records[i].estimated || !run.records[i].estimate.valid) continue;
    CHECK(run.out.frame_poses[k].t_ns == run.frame_t_ns[i]);
    ++k;
  }
  // IMU-rate poses once a pose exists, at the samples' own stamps.
  CHECK(run.out.imu_pose_t_ns.size() >= 9 * run.out.frame_poses.size());  // 200 Hz IMU, 20 Hz camera
  CHECK(run.out.imu_pose_t_ns.back() == run.imu_t_ns.back());
  // Keyframe images: one per frame that the next frame's window slide settled, handed on at
  // that next frame, with the settled frame's own pixels, stamp and name.
  std::size_t kf = 0;
  for (std::size_t i = 1; i < run.records.size(); ++i) {
    if (run.records[i].estimate.settled_frame != run.records[i - 1].estimate.frame_id) continue;
    REQUIRE(kf < run.out.keyframes.size());
    const KeyframeImage& img = run.out.keyframes[kf++];
    CHECK(img.t_ns == run.frame_t_ns[i - 1]);
    CHECK(img.id == run.records[i - 1].estimate.frame_id);
    CHECK(img.left.valid());
    CHECK(img.pixel_sum == run.left_sum[i - 1]);
    CHECK(img.left.width == 752);
    CHECK(img.left.height == 480);
    CHECK(img.n_features >= 50);  // the frame's tracked features come with it (textured room)
  }
  CHECK(kf == run.out.keyframes.size());
  CHECK(kf >= 10);  // the frames that filled the window at least
  CHECK(run.steady_allocations == 0);
}

// The back end as an executor's tasks (two cores): what comes out is what the inline pipeline
// gives, bit for bit, although each frame's back end runs after the reader moved on.
TEST_CASE("pipeline with a back-end executor: the same poses, keyframe images and records as inline, 0 allocations",
          "[pipeline]") {
  const Run inline_run = run_micro(0.0);
  DeferredExecutor executor;
  const Run deferred = run_micro(0.0, false, {}, &executor);
  CHECK(executor.deepest >= 10);  // a frame's back end and the IMU samples after it waited
  REQUIRE(deferred.records.size() == inline_run.records.size());
  REQUIRE(deferred.out.frame_poses.size() == inline_run.out.frame_poses.size());
  CHECK(deferred.out.frame_poses.size() >= 80);
  CHECK(mismatches(inline_run.out.frame_poses, deferred.out.frame_poses, [](const FramePose& a, const FramePose& b) {
          return a.t_ns != b.t_ns || a.id != b.id || a.keyframe != b.keyframe;
        }) == 0);
  CHECK(mismatches(inline_run.records, deferred.records, [](const auto& ra, const auto& rb) {
          const ums::EstimatorOutput &a = ra.estimate, &b = rb.estimate;
          return a.p_w_b != b.p_w_b || a.q_w_b.coeffs() != b.q_w_b.coeffs() || a.v_w_b != b.v_w_b;
        }) == 0);  // bit for bit
  CHECK(deferred.out.imu_pose_t_ns == inline_run.out.imu_pose_t_ns);
  // Keyframe images with the settled frame's own pixels, though the reader has moved on since.
  REQUIRE(deferred.out.keyframes.size() == inline_run.out.keyframes.size());
  CHECK(deferred.out.keyframes.size() >= 10);
  CHECK(mismatches(inline_run.out.keyframes, deferred.out.keyframes, [](const KeyframeImage& a, const KeyframeImage& b) {
          return a.id != b.id || a.t_ns != b.t_ns || a.pixel_sum != b.pixel_sum || a.n_features != b.n_features;
        }) == 0);
  CHECK(deferred.counters.keyframes == inline_run.counters.keyframes);
  CHECK(deferred.steady_allocations == 0);
}

TEST_CASE("pipeline: a back-end executor is refused with estimate_td (frame k's estimate stamps frame k+1)", "[pipeline]") {
  ums::hal::EurocReader reader;
  reader.open(ums::test::euroc_micro_dir(), ums::hal::EurocReaderOptions());
  ums::VioPipelineOptions po;
  ums::EstimatorOptions eo;
  eo.focal_px = reader.calibration().cam[0].fx;
  eo.keyframe.focal_px = static_cast<float>(eo.focal_px);
  eo.preintegration.noise = ums::ImuNoise::from_calibration(reader.calibration().imu);
  eo.estimate_td = true;
  ums::VioPipeline pipeline(po, ums::FrontendOptions(), eo, reader.calibration());
  DeferredExecutor executor;
  CHECK_THROWS_AS(pipeline.set_backend_executor(&executor), std::invalid_argument);
  CHECK_NOTHROW(pipeline.set_backend_executor(nullptr));
}

// Samples that are no reading (NaN, 1e9 on every axis as from a glitching driver, -Inf) never
// reach the estimator: they are dropped and counted, not ramped in by the slew limiter. The vehicle
// rests in the micro sequence, so 0.1 s of each, at 1.5, 2.5 and 3.5 s, must leave the poses where
// the clean run has them. (One run with all three: each run is 20 s under qemu.)
TEST_CASE("pipeline: NaN and huge IMU samples are dropped and counted, the poses stay put", "[pipeline][slow]") {
  const Run clean = run_micro(0.0);
  const Run bad = run_micro(0.0, false,
                            {ImuCorruption{300, 20, std::nan("")}, ImuCorruption{500, 20, 1e9},
                             ImuCorruption{700, 20, -std::numeric_limits<double>::infinity()}});
  CHECK(bad.counters.imu_implausible == 60);
  CHECK(bad.counters.imu_samples == clean.counters.imu_samples - 60);
  CHECK(bad.counters.saturated_samples == clean.counters.saturated_samples);
  REQUIRE(bad.records.size() == clean.records.size());
  double worst_m = 0.0;
  for (std::size_t i = 0; i < bad.records.size(); ++i) {
    const ums::EstimatorOutput& a = bad.records[i].estimate;
    const ums::EstimatorOutput& b = clean.records[i].estimate;
    if (!a.valid || !b.valid) continue;
    REQUIRE(a.p_w_b.allFinite());
    worst_m = std::max(worst_m, (a.p_w_b - b.p_w_b).norm());
  }
  CHECK(worst_m < 0.005);  // m
  CHECK(bad.steady_allocations == 0);
}

// What the configuration did not plan for (issue 20 item 4): pairs larger than the calibration
// (1280x800 into a 752x480 pipeline) are refused and counted; a 2 kHz IMU (10x EuRoC's) fits the
// preintegration without a drop; white-noise images (corners everywhere, far more than max_cnt)
// give at most max_cnt features. Memory stays fixed: no allocation once running.
TEST_CASE("pipeline under overload: oversized pairs refused, a 2 kHz IMU, corners everywhere", "[pipeline][slow]") {
  ums::hal::EurocReader reader;
  reader.open(ums::test::euroc_micro_dir(), ums::hal::EurocReaderOptions());
  auto pipeline = make_pipeline(reader.calibration(), false);
  Run run;
  RecordObserver observer;
  observer.records = &run.records;
  observer.estimated_valid = &run.estimated_valid;
  run.records.reserve(kReserve);
  pipeline->set_frame_observer(&observer);
  std::vector<std::uint8_t> big(1280 * 800, 128), noise[2] = {std::vector<std::uint8_t>(752 * 480),
                                                              std::vector<std::uint8_t>(752 * 480)};
  std::uint32_t state = 7;
  constexpr int kFrames = 40, kBig = 10, kImuPerFrame = 100;  // 20 Hz pairs, 2 kHz IMU
  std::uint64_t steady_allocations = 0;
  int most_features = 0;
  for (int k = 0; k < kFrames; ++k) {
    ums::AllocScope scope;
    for (int i = 0; i < kImuPerFrame; ++i) {
      ums::ImuSample s;
      s.t_ns = 1'000'000'000LL + (k * kImuPerFrame + i) * 500'000LL;
      s.gyro_rad_s = Eigen::Vector3d(0.01, -0.02, 0.005);
      s.accel_m_s2 = Eigen::Vector3d(0.0, 0.0, 9.81);
      pipeline->on_imu(s);
    }
    ums::StereoFrame frame;
    frame.t_ns = 1'000'000'000LL + (k + 1) * kImuPerFrame * 500'000LL;
    frame.seq = static_cast<std::uint64_t>(k);
    if (k < kBig) {
      frame.left = frame.right = ums::ImageView{big.data(), 1280, 800, 1280};
    } else {
      for (auto& img : noise)
        for (auto& v : img) v = static_cast<std::uint8_t>((state = state * 1664525u + 1013904223u) >> 24);
      frame.left = ums::ImageView{noise[0].data(), 752, 480, 752};
      frame.right = ums::ImageView{noise[1].data(), 752, 480, 752};
    }
    pipeline->on_stereo(frame);
    const int n = static_cast<int>(pipeline->features().features.size());
    CHECK(n <= ums::FrontendOptions().max_cnt);
    if (k >= kBig) most_features = std::max(most_features, n);
    if (k >= 25) steady_allocations += scope.allocations();
  }
  pipeline->flush();
  const ums::VioPipelineCounters c = pipeline->counters();
  CHECK(c.frames == kFrames);
  CHECK(c.frontend_rejected_frames == kBig);
  CHECK(c.imu_samples == static_cast<std::uint64_t>(kFrames * kImuPerFrame));
  REQUIRE(pipeline->estimator() != nullptr);
  CHECK(pipeline->estimator()->stats().drops_imu == 0);
  int full_frames = 0;
  for (const ums::VioFrameRecord& r : run.records) {
    if (r.frontend_status != ums::Status::kOk) continue;
    CHECK(r.estimate.p_w_b.allFinite());
    ++full_frames;
  }
  CHECK(full_frames == kFrames - kBig);
  CHECK(most_features == ums::FrontendOptions().max_cnt);  // the budget filled, never more
  CHECK(steady_allocations == 0);
}

// A clock stepping back (issue 20's clock-jump fault): the samples stamped before the last one are
// dropped and counted, and the time that passed with them, which no stamp shows, reaches the
// estimator as a hole in the interval it falls in (imu_gap_frames). A pair delivered in swapped
// order is one such sample and no lost time; a copy of the last stamp neither.
TEST_CASE("pipeline: a clock stepping back drops the samples and marks the interval as a hole", "[pipeline]") {
  ums::hal::EurocReader reader;
  reader.open(ums::test::euroc_micro_dir(), ums::hal::EurocReaderOptions());
  const auto run = [&](int back_samples) {
    auto pipeline = make_pipeline(reader.calibration(), false);
    std::vector<std::uint8_t> gray(752 * 480, 128);
    std::int64_t t_ns = 1'000'000'000LL;
    for (int k = 0; k < 12; ++k) {
      for (int i = 0; i < 10; ++i) {
        ums::ImuSample s;
        s.t_ns = (t_ns += 5'000'000LL);
        s.accel_m_s2 = Eigen::Vector3d(0.0, 0.0, 9.81);
        pipeline->on_imu(s);
        if (k == 6 && i == 4) {
          // The clock steps back by back_samples periods: the samples that follow repeat the
          // stamps already seen until they pass the last one.
          t_ns -= back_samples * 5'000'000LL;
          for (int b = 0; b < back_samples; ++b) {
            s.t_ns = (t_ns += 5'000'000LL) - 5'000'000LL;
            pipeline->on_imu(s);
          }
        }
      }
      ums::StereoFrame frame;
      frame.t_ns = t_ns;
      frame.left = frame.right = ums::ImageView{gray.data(), 752, 480, 752};
      pipeline->on_stereo(frame);
    }
    pipeline->flush();
    REQUIRE(pipeline->estimator() != nullptr);
    return std::make_pair(pipeline->counters().imu_out_of_order, pipeline->estimator()->stats().imu_gap_frames);
  };
  const auto none = run(0);
  CHECK(none.first == 0);
  CHECK(none.second == 0);
  const auto swapped = run(1);  // one sample stamped one period back: a swapped pair
  CHECK(swapped.first == 1);
  CHECK(swapped.second == 0);
  const auto stepped = run(60);  // 0.3 s back
  CHECK(stepped.first == 60);
  CHECK(stepped.second == 1);
}

// The estimator names its frames (EstimatorOutput::frame_id): the keyframe outlet passes the name
// on, and names never repeat.
TEST_CASE("pipeline: keyframe images arrive with increasing FrameIds", "[pipeline][slow]") {
  const Run run = run_micro(0.0);
  REQUIRE(run.out.keyframes.size() >= 2);
  for (std::size_t i = 0; i < run.out.keyframes.size(); ++i) {
    CHECK(run.out.keyframes[i].id != ums::kNoFrame);
    if (i > 0) CHECK(run.out.keyframes[i].id > run.out.keyframes[i - 1].id);
  }
}

// A camera 4 ms behind the IMU: every frame goes on at its stamp + td, once the IMU has reached
// that time (core/pipeline/time_aligner.hpp); the last frame of the recording, which the IMU
// never reaches, goes on at the end (flush). The IMU-rate poses stay at the samples' stamps.
TEST_CASE("pipeline: rig td_s puts every frame at its stamp + td, after the IMU up to it", "[pipeline][slow]") {
  constexpr double kTdS = 0.004;  // s, camera clock behind the IMU by 4 ms
  constexpr std::int64_t kTdNs = 4'000'000;
  const Run base = run_micro(0.0);
  const Run shifted = run_micro(kTdS);
  REQUIRE(shifted.frame_t_ns == base.frame_t_ns);
  REQUIRE(shifted.records.size() == base.records.size());
  for (std::size_t i = 0; i < shifted.records.size(); ++i) {
    CHECK(shifted.records[i].t_ns == base.frame_t_ns[i] + kTdNs);
  }
  // Poses and keyframe images at the shifted stamps (the estimates themselves differ a little:
  // each frame's IMU interval now ends at its own time, not 4 ms early).
  REQUIRE(shifted.out.frame_poses.size() == base.out.frame_poses.size());
  for (const FramePose& p : shifted.out.frame_poses) {
    CHECK(std::count(base.frame_t_ns.begin(), base.frame_t_ns.end(), p.t_ns - kTdNs) == 1);
  }
  REQUIRE(shifted.out.keyframes.size() == base.out.keyframes.size());
  for (const KeyframeImage& k : shifted.out.keyframes) {
    CHECK(std::count(base.frame_t_ns.begin(), base.frame_t_ns.end(), k.t_ns - kTdNs) == 1);
  }
  REQUIRE(!shifted.out.imu_pose_t_ns.empty());
  CHECK(shifted.out.imu_pose_t_ns.back() == shifted.imu_t_ns.back());
  CHECK(shifted.steady_allocations == 0);
}

TEST_CASE("pipeline: frontend_only runs the front end and produces no pose and no keyframe", "[pipeline][slow]") {
  const Run run = run_micro(0.0, true);
  CHECK(run.counters.frames == 95);
  CHECK(run.counters.keyframes == 0);
  CHECK(run.out.frame_poses.empty());
  CHECK(run.out.imu_pose_t_ns.empty());
  CHECK(run.out.keyframes.empty());
  for (const ums::VioFrameRecord& r : run.records) {
    CHECK(r.frontend_status == ums::Status::kOk);
    CHECK_FALSE(r.estimated);
  }
  CHECK(run.steady_allocations == 0);
}
