#include "hal/d455/recorder.hpp"

#include <catch2/catch.hpp>

#include "tests/common/test_paths.hpp"
#include "tests/hal/d455/fake_kernel.hpp"

using namespace ums::d455;
using ums::Status;

namespace {
class CountingSink : public ums::MeasurementSink {
 public:
  void on_imu(const ums::ImuSample& s) override {
    ordered = ordered && s.t_ns > last_imu;
    last_imu = s.t_ns;
    ++imu;
  }
  void on_stereo(const ums::StereoFrame& f) override {
    ordered = ordered && f.t_ns > last_frame && last_imu >= f.t_ns;  // IMU covers each frame
    last_frame = f.t_ns;
    ++frames;
  }
  std::uint64_t imu = 0, frames = 0;
  std::int64_t last_imu = 0, last_frame = 0;
  bool ordered = true;
};

struct Session {
  std::string root;
  test::FakeKernel kernel;
  int frames_left;
  std::int64_t t = 1'000'000'000LL;
  explicit Session(const std::string& name, int frames) : root(ums::test::make_temp_dir(name)), frames_left(frames) {
    test::build_d455_tree(root, &kernel);
    kernel.sleep_on_timeout = true;
    // Each poll: 10 ms of data (4 gyro, ~2-3 accel) and a frame every third poll.
    kernel.on_poll = [this](int poll) {
      if (frames_left <= 0) return;
      for (int i = 0; i < 4; ++i) {
        t += 2'500'000;
        kernel.push_iio(root + "/dev/iio:device1", test::iio_record(0, 0, 0, t));
        if (i % 2 == 0) kernel.push_iio(root + "/dev/iio:device0", test::iio_record(0, -1000, 0, t + 1));
      }
      if (poll % 3 == 0) {
        test::FakeFrameSpec s;
        s.driver_ns = t - 5'000'000;
        s.with_meta = false;
        if (kernel.produce_frame(root + "/dev/video2", poll, s)) --frames_left;
      }
    };
  }
  D455Options options() const {
    D455Options o;
    o.imu.clock = ImuClock::kHostMonotonic;
    o.camera.use_metadata = false;
    return o;
  }
};
}  // namespace

TEST_CASE("Recorder restarts a stalled stream once, then gives up with kTimeout, keeping what it wrote", "[d455][recorder]") {
  Session session("d455_record_stall", 30);
  SysFs fs(session.root);
  D455Device dev(session.kernel, fs, session.options());
  std::string error;
  REQUIRE(dev.open(&error) == Status::kOk);
  RecordOptions ro;
  ro.poll_timeout_ms = 5;
  ro.stall_restart_ms = 40;
  ro.stall_give_up_ms = 120;
  CountingSink sink;
  RecordSummary summary;
  const Status s = record(dev, sink, ro, nullptr, &summary, &error);
  CHECK(s == Status::kTimeout);
  INFO("gyro " << summary.device.gyro.records << " accel " << summary.device.accel.records << " fused " << summary.device.fuser.emitted << " unbr " << summary.device.fuser.gyro_unbracketed << " ovf " << summary.device.fuser.gyro_overflow << " mal " << summary.device.gyro.malformed << " ooo " << summary.device.gyro.out_of_order);
  CHECK(error.find("no data for") != std::string::npos);
  CHECK(summary.frames == 30);
  CHECK(sink.frames == 30);
  CHECK(summary.imu_samples == sink.imu);
  CHECK(summary.imu_samples >= 300);
  CHECK(summary.restarts == 1);
  CHECK(session.kernel.video(session.root + "/dev/video2")->streamon_count == 2);
  CHECK(sink.ordered);
  CHECK(summary.duration_s >= 0.12);
}

TEST_CASE("Recorder stops at the requested duration or on the stop flag with kOk", "[d455][recorder]") {
  Session session("d455_record_time", 1000000);
  SysFs fs(session.root);
  D455Device dev(session.kernel, fs, session.options());
  std::string error;
  REQUIRE(dev.open(&error) == Status::kOk);
  RecordOptions ro;
  ro.seconds = 0.05;
  CountingSink sink;
  RecordSummary summary;
  CHECK(record(dev, sink, ro, nullptr, &summary, &error) == Status::kOk);
  CHECK(summary.duration_s >= 0.05);
  CHECK(summary.duration_s < 2.0);
  CHECK(summary.frames > 0);
  // A second session on the same device: camera and IMU both come back after stop().
  CHECK(record(dev, sink, ro, nullptr, &summary, &error) == Status::kOk);
  CHECK(summary.frames > 0);
  CHECK(summary.imu_samples > 0);
  std::atomic<bool> stop{true};
  ro.seconds = 0.0;
  CHECK(record(dev, sink, ro, &stop, &summary, &error) == Status::kOk);
  CHECK(summary.frames == 0);
}

TEST_CASE("Recorder ends with kIoError when the camera is unplugged mid-session", "[d455][recorder]") {
  Session session("d455_record_unplug", 1000000);
  SysFs fs(session.root);
  D455Device dev(session.kernel, fs, session.options());
  std::string error;
  REQUIRE(dev.open(&error) == Status::kOk);
  auto script = session.kernel.on_poll;
  session.kernel.on_poll = [&](int poll) {
    script(poll);
    if (poll == 50) session.kernel.unplug();
  };
  RecordOptions ro;
  ro.seconds = 5.0;
  CountingSink sink;
  RecordSummary summary;
  CHECK(record(dev, sink, ro, nullptr, &summary, &error) == Status::kIoError);
  CHECK(error.find("unplugged") != std::string::npos);
  CHECK(summary.frames >= 10);
  CHECK(summary.duration_s < 1.0);
}
