#include "hal/d455/record_euroc.hpp"

#include <catch2/catch.hpp>

#include <vector>

#include "hal/d455/nominal_calibration.hpp"
#include "hal/replay/euroc_reader.hpp"
#include "tests/common/test_paths.hpp"
#include "tests/hal/d455/fake_kernel.hpp"

using namespace ums::d455;
using ums::Status;

TEST_CASE("A recorded fake-device session replays through EurocReader with the same frames, pixels and IMU", "[d455][record]") {
  const std::string root = ums::test::make_temp_dir("d455_record_euroc_dev");
  const std::string out = ums::test::make_temp_dir("d455_record_euroc_out");
  test::FakeKernel kernel;
  test::build_d455_tree(root, &kernel);
  std::atomic<bool> stop{false};
  std::vector<int> seeds;
  std::int64_t t = 1'000'000'000LL;
  kernel.on_poll = [&](int poll) {
    if (seeds.size() >= 12) {
      if (poll > 200) stop = true;  // let the last frame's IMU arrive
      return;
    }
    for (int i = 0; i < 4; ++i) {  // 10 ms of IMU per poll: gyro 400 Hz, accel 200 Hz
      t += 2'500'000;
      kernel.push_iio(root + "/dev/iio:device1", test::iio_record(0, 0, 10, t));
      if (i % 2 == 0) kernel.push_iio(root + "/dev/iio:device0", test::iio_record(0, -1000, 0, t + 1));
    }
    if (poll % 3 == 0) {
      test::FakeFrameSpec s;
      s.driver_ns = t - 20'000'000;
      s.with_meta = false;
      if (kernel.produce_frame(root + "/dev/video2", poll, s)) seeds.push_back(poll);
    }
  };
  ums::d455::SysFs fs(root);
  D455Options o;
  o.imu.clock = ImuClock::kHostMonotonic;
  o.camera.use_metadata = false;
  D455Device dev(kernel, fs, o);
  std::string error;
  REQUIRE(dev.open(&error) == Status::kOk);
  RecordOptions ro;
  ro.poll_timeout_ms = 1;
  ro.stall_restart_ms = 1000;
  ro.stall_give_up_ms = 2000;
  RecordSummary summary;
  const auto calibration = d455_nominal_calibration(848, 480, 30.0, 400.0);
  REQUIRE(record_euroc(dev, calibration, out, ro, &stop, &summary, &error) == Status::kOk);
  REQUIRE(summary.frames == 12);

  ums::hal::EurocReader reader;
  reader.open(out);
  CHECK(reader.calibration().cam[0].fx == Approx(429.278));
  CHECK((reader.calibration().cam[1].T_b_c.translation() - reader.calibration().cam[0].T_b_c.translation()).x() ==
        Approx(0.095));
  ums::ImuSample imu;
  ums::StereoFrame frame;
  std::size_t frames = 0, imu_count = 0;
  int wrong = 0;
  double max_gyro_err = 0.0;
  for (;;) {
    const auto e = reader.next(&imu, &frame);
    if (e == ums::hal::EurocReader::Event::kEnd) break;
    if (e == ums::hal::EurocReader::Event::kImu) {
      ++imu_count;
      // raw z = 10 x 0.1 deg/s -> body z = -1 deg/s (diag(-1,1,-1)).
      max_gyro_err = std::max(max_gyro_err, std::abs(imu.gyro_rad_s.z() + M_PI / 180.0));
      continue;
    }
    REQUIRE(frames < seeds.size());
    const int seed = seeds[frames++];
    for (int y = 0; y < frame.left.height; y += 37) {
      for (int x = 0; x < frame.left.width; x += 41) {
        wrong += frame.left.row(y)[x] != test::FakeKernel::left_pixel(x, y, seed);
        wrong += frame.right.row(y)[x] != test::FakeKernel::right_pixel(x, y, seed);
      }
    }
  }
  CHECK(reader.status() == Status::kOk);
  CHECK(frames == 12);
  CHECK(wrong == 0);
  CHECK(reader.summary().imu_rows == summary.imu_samples);
  CHECK(imu_count > 100);
  CHECK(max_gyro_err < 1e-6);  // rad/s, through the CSV's printed precision
}
