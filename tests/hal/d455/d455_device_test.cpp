#include "hal/d455/d455_device.hpp"

#include <catch2/catch.hpp>

#include <cmath>
#include <filesystem>
#include <vector>

#include "profiling/alloc_counter.hpp"
#include "tests/common/test_paths.hpp"
#include "tests/hal/d455/fake_kernel.hpp"

using namespace ums::d455;
using ums::Status;

namespace {

struct Event {
  bool frame;
  std::int64_t t_ns;
  double accel_x;
};

class CollectingSink : public ums::MeasurementSink {
 public:
  void on_imu(const ums::ImuSample& s) override { events.push_back({false, s.t_ns, s.accel_m_s2.x()}); }
  void on_stereo(const ums::StereoFrame& f) override {
    events.push_back({true, f.t_ns, 0.0});
    pixel_ok = pixel_ok && f.left.row(10)[20] == test::FakeKernel::left_pixel(20, 10, static_cast<int>(frames)) &&
               f.right.row(10)[20] == test::FakeKernel::right_pixel(20, 10, static_cast<int>(frames));
    ++frames;
  }
  std::vector<Event> events;
  std::uint64_t frames = 0;
  bool pixel_ok = true;
};

// A scripted D455: simulated time advances 2.5 ms per poll; gyro at 400 Hz, accel at 250 Hz with
// raw x = t_ms (so body x = -t_ms mg, linear in time), frames at 30 Hz stamped on the same clock.
struct Script {
  test::FakeKernel* kernel;
  std::string root;
  std::int64_t t0_ns = 10'000'000'000LL;
  std::int64_t next_accel_ns = 10'000'000'000LL;
  std::int64_t next_frame_ns = 10'010'000'000LL;
  int frames = 0;
  int max_frames = 1000;
  void step(int poll) {
    const std::int64_t t = t0_ns + static_cast<std::int64_t>(poll) * 2'500'000;
    kernel->push_iio(root + "/dev/iio:device1", test::iio_record(1, 2, 3, t));
    while (next_accel_ns <= t) {
      kernel->push_iio(root + "/dev/iio:device0",
                       test::iio_record(static_cast<std::int32_t>((next_accel_ns - t0_ns) / 1'000'000), -1000, 0, next_accel_ns));
      next_accel_ns += 4'000'000;
    }
    if (next_frame_ns <= t && frames < max_frames) {
      test::FakeFrameSpec s;
      s.driver_ns = next_frame_ns;
      s.with_meta = false;
      kernel->produce_frame(root + "/dev/video2", frames++, s);
      next_frame_ns += 33'333'333;
    }
  }
};

D455Options host_clock_options() {
  D455Options o;
  o.imu.clock = ImuClock::kHostMonotonic;  // the fake's stamps are the simulated clock itself
  o.camera.use_metadata = false;
  o.max_frame_hold_ms = 1000;
  return o;
}

}  // namespace

TEST_CASE("D455Device delivers fused IMU and frames in time order, each frame after the IMU covering it", "[d455][device]") {
  const std::string root = ums::test::make_temp_dir("d455_device");
  test::FakeKernel kernel;
  test::build_d455_tree(root, &kernel);
  SysFs fs(root);
  Script script{&kernel, root};
  kernel.on_poll = [&](int poll) { script.step(poll); };
  D455Device dev(kernel, fs, host_clock_options());
  std::string error;
  REQUIRE(dev.open(&error) == Status::kOk);
  REQUIRE(dev.has_imu());
  REQUIRE(dev.start(&error) == Status::kOk);
  CollectingSink sink;
  for (int k = 0; k < 400; ++k) REQUIRE(dev.poll_once(sink, 10) == Status::kOk);  // 1 s simulated
  dev.flush(sink);
  // Per-stream order, and every frame preceded by an IMU sample at or after its stamp.
  int out_of_order = 0, frames = 0, imu = 0, uncovered = 0;
  std::int64_t last_imu = INT64_MIN, last_frame = INT64_MIN;
  double max_interp_err = 0.0;
  for (const Event& e : sink.events) {
    if (e.frame) {
      out_of_order += e.t_ns <= last_frame;
      uncovered += last_imu < e.t_ns;
      last_frame = e.t_ns;
      ++frames;
    } else {
      out_of_order += e.t_ns <= last_imu || e.t_ns < last_frame;
      last_imu = e.t_ns;
      ++imu;
      const double t_ms = static_cast<double>(e.t_ns - script.t0_ns) * 1e-6;
      max_interp_err = std::max(max_interp_err, std::abs(e.accel_x - (-t_ms * 0.001 * 9.80665)));
    }
  }
  CHECK(out_of_order == 0);
  CHECK(uncovered == 0);
  CHECK(frames == 30);                  // 10 ms .. 976 ms at 30 Hz
  CHECK(imu >= 395);                    // 400 gyro samples, the last ones waiting for accel
  CHECK(max_interp_err < 1e-9);         // m/s^2: accel interpolated onto gyro stamps
  CHECK(sink.pixel_ok);
  const D455Stats st = dev.stats();
  CHECK(st.frames_released_without_imu == 0);
  CHECK(st.imu_behind_frame == 0);
  CHECK(st.accel.malformed + st.gyro.malformed == 0);

  // Steady state allocates nothing: data queued beforehand, then drained.
  kernel.on_poll = nullptr;
  for (int k = 400; k < 440; ++k) script.step(k);  // 100 ms: 40 gyro, 25 accel, 3 frames
  CollectingSink quiet;
  quiet.events.reserve(1000);
  ums::AllocScope scope;
  for (int k = 0; k < 20; ++k) dev.poll_once(quiet, 0);
  CHECK(scope.allocations() == 0);
  CHECK(quiet.frames == 3);
}

TEST_CASE("D455Device reports an unplugged camera as kIoError", "[d455][device]") {
  const std::string root = ums::test::make_temp_dir("d455_device_unplug");
  test::FakeKernel kernel;
  test::build_d455_tree(root, &kernel);
  SysFs fs(root);
  D455Device dev(kernel, fs, host_clock_options());
  std::string error;
  REQUIRE(dev.open(&error) == Status::kOk);
  REQUIRE(dev.start(&error) == Status::kOk);
  CollectingSink sink;
  CHECK(dev.poll_once(sink, 0) == Status::kTimeout);
  kernel.unplug();
  CHECK(dev.poll_once(sink, 0) == Status::kIoError);
}

TEST_CASE("D455Device without IIO devices fails unless images alone are allowed", "[d455][device]") {
  const std::string root = ums::test::make_temp_dir("d455_device_noimu");
  test::FakeKernel kernel;
  test::build_d455_tree(root, &kernel);
  std::filesystem::remove(root + "/sys/bus/iio/devices/iio:device0");
  SysFs fs(root);
  std::string error;
  {
    D455Device dev(kernel, fs, host_clock_options());
    CHECK(dev.open(&error) == Status::kUnsupported);
    CHECK(error.find("CONFIG_HID_SENSOR") != std::string::npos);
  }
  D455Options o = host_clock_options();
  o.require_imu = false;
  D455Device dev(kernel, fs, o);
  REQUIRE(dev.open(&error) == Status::kOk);
  REQUIRE(dev.start(&error) == Status::kOk);
  test::FakeFrameSpec s;
  s.driver_ns = 5'000'000'000LL;
  kernel.produce_frame(root + "/dev/video2", 0, s);
  CollectingSink sink;
  REQUIRE(dev.poll_once(sink, 0) == Status::kOk);
  CHECK(sink.frames == 1);  // released at once: no IMU to wait for
}
