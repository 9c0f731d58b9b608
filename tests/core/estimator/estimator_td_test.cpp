// estimate_td end to end on a rendered flight (host only: rendering under qemu is slow). The
// images are planted 10 ms late against the IMU and the calibration says 0: the window's time
// offset must find the 10 ms from the image velocities; with estimate_td off it stays at 0. The
// estimating run goes through the product's pipeline, whose time aligner restamps each new frame
// with the estimate; the fixed one feeds the estimator directly.

#include <cmath>
#include <memory>
#include <string>

#include <catch2/catch.hpp>

#include "core/estimator/window.hpp"
#include "core/pipeline/vio_pipeline.hpp"
#include "hal/replay/euroc_reader.hpp"
#include "hal/sim/simulate.hpp"
#include "tests/common/test_paths.hpp"
#include "tests/core/estimator/dataset_run.hpp"

namespace {

struct TdRun {
  double td_at_10s_ms = 0.0;  // the estimate 10 s after the first frame
  double td_end_ms = 0.0;
  bool vio = false;
  std::uint64_t resets = 0;
  double applied_end_ms = 0.0;  // the offset the last frame was stamped with
};

// Every frame as the pipeline processed it: the estimate after it and the offset it carried.
struct TdObserver final : ums::FrameObserver {
  void on_frame_done(const ums::VioFrameRecord& record, const ums::StereoFrame& frame) override {
    if (!record.estimated || !record.estimate.valid) return;
    if (t0_ns < 0) t0_ns = record.t_ns;
    if (record.t_ns - t0_ns <= 10'000'000'000LL) r.td_at_10s_ms = record.estimate.td_s * 1e3;
    r.td_end_ms = record.estimate.td_s * 1e3;
    r.applied_end_ms = static_cast<double>(frame.td_ns) * 1e-6;
    r.vio = record.estimate.mode == ums::EstimatorMode::kVio;
  }
  std::int64_t t0_ns = -1;
  TdRun r;
};

TdRun run_pipeline(const std::string& data) {
  ums::hal::EurocReader reader;
  reader.open(data, ums::hal::EurocReaderOptions());
  const ums::RigCalibration rig = reader.calibration();
  ums::EstimatorOptions eo;
  eo.focal_px = rig.cam[0].fx;
  eo.estimate_td = true;
  ums::VioPipeline vio(ums::VioPipelineOptions(), ums::FrontendOptions(), eo, rig);
  TdObserver observer;
  vio.set_frame_observer(&observer);
  ums::ImuSample imu;
  ums::StereoFrame frame;
  for (;;) {
    const auto ev = reader.next(&imu, &frame);
    if (ev == ums::hal::EurocReader::Event::kEnd) break;
    if (ev == ums::hal::EurocReader::Event::kImu) vio.on_imu(imu);
    else vio.on_stereo(frame);
  }
  vio.flush();
  observer.r.resets = vio.estimator()->stats().resets;
  return observer.r;
}

// estimate_td off, the estimator fed directly: the offset the window ends with.
double fixed_td_end_ms(const std::string& data) {
  ums::hal::EurocReader reader;
  reader.open(data, ums::hal::EurocReaderOptions());
  const ums::RigCalibration rig = reader.calibration();
  ums::EstimatorOptions eo;
  eo.focal_px = rig.cam[0].fx;
  ums::EstimatorOutput out;
  const auto est = ums::test::run_dataset(reader, rig, eo, &out, [](std::int64_t, const ums::EstimatorOutput&) {});
  return est->window().time_offset().value_s() * 1e3;
}

}  // namespace

TEST_CASE("estimate_td: a planted 10 ms camera delay is found from the image velocities on a rendered flight",
          "[estimator][td]") {
  const std::string dir = ums::test::make_temp_dir("td_v101");
  ums::sim::SimOptions so;
  so.trajectory_path = ums::test::groundtruth_dir() + "/V101_GT.txt";
  so.duration_s = 16.0;
  so.td_s = 0.010;
  so.out_dir = dir + "/data";
  std::string error;
  REQUIRE(ums::sim::simulate(so, &error) == 0);
  const double fixed_td_ms = fixed_td_end_ms(so.out_dir);
  const TdRun free = run_pipeline(so.out_dir);
  INFO("estimated: " << free.td_at_10s_ms << " ms at 10 s, " << free.td_end_ms << " ms at the end, frames stamped with "
                     << free.applied_end_ms << " ms");
  CHECK(fixed_td_ms == 0.0);  // held at the calibration bit for bit
  CHECK(free.vio);
  CHECK(free.resets == 0);
  // Measured 2026-12-04 (frames restamped with the estimate): 9.99 ms at 10 s, 10.06 ms at the
  // end (9.74 / 9.92 ms when every frame carried the calibration's 0). The D455 V102 flight at
  // 30 Hz settles within 0.15 ms of -8 / +5 / +12 ms by 20 s (docs/results.md).
  CHECK(std::abs(free.td_end_ms - 10.0) < 0.5);
  CHECK(std::abs(free.td_at_10s_ms - 10.0) < 1.0);
  // The frames go on restamped with the estimate (to the ns), so little is left to model.
  CHECK(std::abs(free.applied_end_ms - free.td_end_ms) < 0.5);
}
