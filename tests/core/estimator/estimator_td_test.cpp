// estimate_td end to end on a rendered flight (host only: rendering under qemu is slow). The
// images are planted 10 ms late against the IMU and the calibration says 0: the window's time
// offset must find the 10 ms from the image velocities; with estimate_td off it stays at 0.

#include <cmath>
#include <memory>
#include <string>

#include <catch2/catch.hpp>

#include "core/estimator/window.hpp"
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
};

TdRun run(const std::string& data, bool estimate) {
  ums::hal::EurocReader reader;
  reader.open(data, ums::hal::EurocReaderOptions());
  const ums::RigCalibration rig = reader.calibration();
  ums::EstimatorOptions eo;
  eo.focal_px = rig.cam[0].fx;
  eo.estimate_td = estimate;
  ums::EstimatorOutput out;
  TdRun r;
  std::int64_t t0_ns = -1;
  const auto est = ums::test::run_dataset(reader, rig, eo, &out, [&](std::int64_t t_ns, const ums::EstimatorOutput& o) {
    if (t0_ns < 0) t0_ns = t_ns;
    if (t_ns - t0_ns <= 10'000'000'000LL) r.td_at_10s_ms = o.td_s * 1e3;
  });
  r.td_end_ms = est->window().time_offset().value_s() * 1e3;
  r.vio = out.mode == ums::EstimatorMode::kVio;
  r.resets = est->stats().resets;
  return r;
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
  const TdRun fixed = run(so.out_dir, false);
  const TdRun free = run(so.out_dir, true);
  INFO("estimated: " << free.td_at_10s_ms << " ms at 10 s, " << free.td_end_ms << " ms at the end");
  CHECK(fixed.td_end_ms == 0.0);  // held at the calibration bit for bit
  CHECK(free.vio);
  CHECK(free.resets == 0);
  // Measured 2026-12-03: the D455 V102 flight at 30 Hz settles within 0.4 ms of +12 ms by 20 s
  // (docs/results.md); this 20 Hz EuRoC-preset cut must be within 1 ms by its end.
  CHECK(std::abs(free.td_end_ms - 10.0) < 1.0);
  CHECK(std::abs(free.td_at_10s_ms - 10.0) < 1.5);  // measured 9.74 ms (end: 9.92 ms)
}
