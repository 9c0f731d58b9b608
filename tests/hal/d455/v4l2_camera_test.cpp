#include "hal/d455/v4l2_camera.hpp"

#include <catch2/catch.hpp>

#include <linux/videodev2.h>

#include "profiling/alloc_counter.hpp"
#include "tests/hal/d455/fake_kernel.hpp"

using namespace ums::d455;
using ums::Status;
using ums::StereoFrame;

namespace {
const std::string kVideo = "/fake/dev/video2";
const std::string kMeta = "/fake/dev/video3";

struct Rig {
  test::FakeKernel kernel;
  DeviceClockMap clock;
  Rig(bool with_meta = true) {
    kernel.add_video(kVideo, {V4L2_PIX_FMT_GREY, V4L2_PIX_FMT_Y8I});
    if (with_meta) kernel.add_meta(kMeta);
  }
};

int pixel_errors(const StereoFrame& f, int seed) {
  int wrong = 0;
  for (int y = 0; y < f.left.height; y += 7) {
    for (int x = 0; x < f.left.width; x += 5) {
      wrong += f.left.row(y)[x] != test::FakeKernel::left_pixel(x, y, seed);
      wrong += f.right.row(y)[x] != test::FakeKernel::right_pixel(x, y, seed);
    }
  }
  return wrong;
}
}  // namespace

TEST_CASE("Camera negotiates Y8I 848x480 at 30 fps, maps 4 buffers and sets emitter off, manual exposure, gain", "[d455][v4l2]") {
  Rig rig;
  CameraOptions o;
  o.exposure_us = 5000;
  o.gain = 32;
  V4l2Camera cam(rig.kernel, o, &rig.clock);
  std::string error;
  REQUIRE(cam.open(kVideo, kMeta, &error) == Status::kOk);
  CHECK(error.empty());
  const auto* v = rig.kernel.video(kVideo);
  CHECK(v->pixelformat == V4L2_PIX_FMT_Y8I);
  CHECK(v->width == 848);
  CHECK(v->height == 480);
  CHECK(v->fps_set == 30);
  CHECK(cam.buffer_count() == 4);
  CHECK(cam.meta_format() == V4L2_META_FMT_D4XX);
  CHECK(rig.kernel.mapped() == 8);  // 4 video + 4 metadata buffers
  CHECK(rig.kernel.xu_writes.at(2) == std::vector<std::uint8_t>{0});  // emitter off
  CHECK(rig.kernel.xu_writes.at(0x0B) == std::vector<std::uint8_t>{0});  // AE off
  CHECK(rig.kernel.xu_writes.at(3) == std::vector<std::uint8_t>{0x88, 0x13, 0, 0});  // 5000 µs LE
  CHECK(rig.kernel.ctrl_writes.at(V4L2_CID_GAIN) == 32);
  cam.close();
  CHECK(rig.kernel.mapped() == 0);
  CHECK(rig.kernel.open_fds() == 0);
}

TEST_CASE("Camera refuses a node that substitutes another format for Y8I or cannot do the rate", "[d455][v4l2]") {
  {
    Rig rig;
    rig.kernel.video(kVideo)->substitute_format = true;  // what uvcvideo does on USB2
    V4l2Camera cam(rig.kernel, CameraOptions{}, &rig.clock);
    std::string error;
    CHECK(cam.open(kVideo, kMeta, &error) == Status::kUnsupported);
    CHECK(error.find("refused Y8I 848x480") != std::string::npos);
    CHECK(error.find("YUYV") != std::string::npos);
    CHECK(rig.kernel.open_fds() == 0);
  }
  {
    Rig rig;
    rig.kernel.video(kVideo)->fps = {15, 30};
    CameraOptions o;
    o.fps = 90;
    V4l2Camera cam(rig.kernel, o, &rig.clock);
    std::string error;
    CHECK(cam.open(kVideo, "", &error) == Status::kUnsupported);
    CHECK(error.find("90 fps") != std::string::npos);
  }
  CameraOptions bad;
  bad.width = 1280;
  CHECK_THROWS_WITH(bad.validate(), Catch::Contains("1280x480"));
}

TEST_CASE("Camera cycles a fixed set of buffers: 40 frames through 4 buffers, pixels exact, zero allocations", "[d455][v4l2]") {
  Rig rig(false);
  CameraOptions o;
  o.width = 640;
  o.fps = 60;
  V4l2Camera cam(rig.kernel, o, &rig.clock);
  std::string error;
  REQUIRE(cam.open(kVideo, "", &error) == Status::kOk);
  REQUIRE(cam.start(&error) == Status::kOk);
  StereoFrame f;
  FrameInfo info;
  int wrong = 0;
  std::int64_t last_t = 0;
  std::uint64_t allocations = 0;
  for (int k = 0; k < 40; ++k) {
    test::FakeFrameSpec spec;
    spec.driver_ns = 1'000'000'000LL + k * 16'666'667LL;
    REQUIRE(rig.kernel.produce_frame(kVideo, k, spec));
    ums::AllocScope scope;  // the camera's dequeue + de-interleave only, not the fake's production
    const Status s = cam.next(&f, &info, 100);
    allocations += scope.allocations();
    REQUIRE(s == Status::kOk);
    wrong += pixel_errors(f, k);
    CHECK(f.t_ns == spec.driver_ns / 1000 * 1000);  // timeval has µs resolution
    CHECK(f.t_ns > last_t);
    last_t = f.t_ns;
  }
  CHECK(allocations == 0);
  CHECK(wrong == 0);
  CHECK(f.left.width == 640);
  CHECK(f.seq == 39);
  CHECK(rig.kernel.video(kVideo)->queued.size() == 4);  // every buffer went back to the driver
  CHECK(cam.stats().frames == 40);
  // The driver drops a frame when we hold no queued buffer: produce 6 without dequeuing.
  for (int k = 0; k < 6; ++k) {
    test::FakeFrameSpec spec;
    spec.driver_ns = 3'000'000'000LL + k * 16'666'667LL;
    rig.kernel.produce_frame(kVideo, 100 + k, spec);
  }
  int got = 0;
  while (cam.try_dequeue(&f, &info) == Status::kOk) ++got;
  CHECK(got == 4);
  CHECK(rig.kernel.video(kVideo)->dropped_no_buffer == 2);
  test::FakeFrameSpec spec;
  spec.driver_ns = 4'000'000'000LL;
  rig.kernel.produce_frame(kVideo, 7, spec);
  REQUIRE(cam.try_dequeue(&f, &info) == Status::kOk);
  CHECK(cam.stats().sequence_gaps == 2);  // seen through the v4l2 sequence numbers
}

TEST_CASE("Camera drops errored, short, reordered and duplicate frames and counts each", "[d455][v4l2]") {
  Rig rig(false);
  V4l2Camera cam(rig.kernel, CameraOptions{}, &rig.clock);
  std::string error;
  REQUIRE(cam.open(kVideo, "", &error) == Status::kOk);
  REQUIRE(cam.start(&error) == Status::kOk);
  auto produce = [&](std::int64_t t, bool err, int short_by, int seq) {
    test::FakeFrameSpec s;
    s.driver_ns = t;
    s.error_flag = err;
    s.bytes_short = short_by;
    s.sequence_override = seq;
    rig.kernel.produce_frame(kVideo, 1, s);
  };
  StereoFrame f;
  produce(1'000'000'000, false, 0, 10);
  REQUIRE(cam.try_dequeue(&f, nullptr) == Status::kOk);
  produce(1'033'000'000, true, 0, 11);   // V4L2_BUF_FLAG_ERROR
  produce(1'066'000'000, false, 100, 12);  // short frame
  produce(1'100'000'000, false, 0, 9);    // sequence back
  CHECK(cam.try_dequeue(&f, nullptr) == Status::kEmpty);  // the fake holds 4 buffers: drain
  produce(1'000'000'000, false, 0, 13);   // same timestamp as the first frame
  produce(900'000'000, false, 0, 14);     // earlier timestamp
  CHECK(cam.try_dequeue(&f, nullptr) == Status::kEmpty);
  produce(1'200'000'000, false, 0, 15);
  REQUIRE(cam.try_dequeue(&f, nullptr) == Status::kOk);
  CHECK(f.t_ns == 1'200'000'000);
  CHECK(cam.stats().bad_frames == 2);
  CHECK(cam.stats().out_of_order == 2);
  CHECK(cam.stats().duplicates == 1);
  CHECK(cam.stats().frames == 2);
}

TEST_CASE("A stalled stream times out with kTimeout and recovers, also through restart()", "[d455][v4l2]") {
  Rig rig(false);
  V4l2Camera cam(rig.kernel, CameraOptions{}, &rig.clock);
  std::string error;
  REQUIRE(cam.open(kVideo, "", &error) == Status::kOk);
  REQUIRE(cam.start(&error) == Status::kOk);
  StereoFrame f;
  test::FakeFrameSpec s;
  s.driver_ns = 1'000'000'000;
  rig.kernel.produce_frame(kVideo, 0, s);
  REQUIRE(cam.next(&f, nullptr, 20) == Status::kOk);
  rig.kernel.sleep_on_timeout = true;
  const std::int64_t t0 = monotonic_now_ns();
  CHECK(cam.next(&f, nullptr, 20) == Status::kTimeout);
  CHECK(monotonic_now_ns() - t0 >= 15'000'000);  // it did wait
  CHECK(cam.stats().timeouts == 1);
  s.driver_ns = 1'100'000'000;
  rig.kernel.produce_frame(kVideo, 1, s);
  REQUIRE(cam.next(&f, nullptr, 20) == Status::kOk);
  CHECK(pixel_errors(f, 1) == 0);
  REQUIRE(cam.restart(&error) == Status::kOk);
  CHECK(rig.kernel.video(kVideo)->streamon_count == 2);
  CHECK(rig.kernel.video(kVideo)->queued.size() == 4);
  s.driver_ns = 1'200'000'000;
  rig.kernel.produce_frame(kVideo, 2, s);  // sequence restarts at 0 after STREAMON
  REQUIRE(cam.next(&f, nullptr, 20) == Status::kOk);
  CHECK(cam.stats().out_of_order == 0);
}

TEST_CASE("An unplugged camera gives kIoError, not a crash or a hang", "[d455][v4l2]") {
  Rig rig;
  V4l2Camera cam(rig.kernel, CameraOptions{}, &rig.clock);
  std::string error;
  REQUIRE(cam.open(kVideo, kMeta, &error) == Status::kOk);
  REQUIRE(cam.start(&error) == Status::kOk);
  rig.kernel.unplug();
  StereoFrame f;
  CHECK(cam.next(&f, nullptr, 50) == Status::kIoError);
  CHECK(cam.disconnected());
  CHECK(cam.try_dequeue(&f, nullptr) == Status::kIoError);
  cam.close();  // must not throw or touch freed state
  CHECK(rig.kernel.open_fds() == 0);
}

TEST_CASE("With D4XX metadata the frame time is mid-exposure on the device clock mapped to host time", "[d455][v4l2]") {
  Rig rig;
  V4l2Camera cam(rig.kernel, CameraOptions{}, &rig.clock);
  std::string error;
  REQUIRE(cam.open(kVideo, kMeta, &error) == Status::kOk);
  REQUIRE(cam.start(&error) == Status::kOk);
  // Host = device + 7 s; readout start (PTS) reaches the host 2 ms later (1 ms for frame 3);
  // mid-exposure is 20 ms before PTS.
  const std::int64_t offset_ns = 7'000'000'000LL;
  StereoFrame f;
  FrameInfo info;
  std::int64_t t[4];
  for (int k = 0; k < 4; ++k) {
    test::FakeFrameSpec s;
    s.pts_us = 4'294'920'000u + static_cast<std::uint32_t>(k) * 33'333u;  // wraps at frame 2
    s.sensor_offset_us = 20'000;
    s.frame_counter = static_cast<std::uint32_t>(k);
    const std::int64_t pts_dev_ns = (4'294'920'000LL + k * 33'333LL) * 1000;
    s.driver_ns = pts_dev_ns + offset_ns + (k == 3 ? 1'000'000 : 2'000'000);
    rig.kernel.produce_frame(kVideo, k, s);
    REQUIRE(cam.try_dequeue(&f, &info) == Status::kOk);
    REQUIRE(info.has_device_time);
    t[k] = f.t_ns;
    CHECK(info.device_mid_exposure_us == 4'294'920'000LL + k * 33'333LL - 20'000);  // unwrapped
    CHECK(info.emitter_mode == 0);
    CHECK(info.exposure_us == 8000u);
  }
  // With the 2 ms latency as the best observation, frames map to mid-exposure + 2 ms.
  CHECK(t[2] - ((4'294'920'000LL + 2 * 33'333LL - 20'000) * 1000 + offset_ns) == Approx(2'000'000).margin(1'000));
  CHECK(t[1] - t[0] == 33'333'000);
  // Frame 3 lowered the envelope to 1 ms.
  CHECK(t[3] - ((4'294'920'000LL + 3 * 33'333LL - 20'000) * 1000 + offset_ns) == Approx(1'000'000).margin(1'000));
  CHECK(cam.stats().meta_unmatched == 0);
}
