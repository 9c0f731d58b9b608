#include "hal/d455/thread_bridge.hpp"

#include <catch2/catch.hpp>

#include <atomic>
#include <memory>
#include <thread>
#include <vector>

#include "profiling/alloc_counter.hpp"

using ums::d455::ThreadBridge;

namespace {
constexpr int kW = 64, kH = 48;

std::uint8_t pix(int x, int y, std::uint64_t seq, int side) {
  return static_cast<std::uint8_t>((x + 7 * y + 13 * static_cast<int>(seq) + 101 * side) & 255);
}

// Checks order (per stream and interleaving), pixels, and counts.
class CheckingSink : public ums::MeasurementSink {
 public:
  void on_imu(const ums::ImuSample& s) override {
    order_ok = order_ok && s.t_ns > last_imu && s.gyro_rad_s.x() == static_cast<double>(s.t_ns);
    last_imu = s.t_ns;
    last_any = s.t_ns;
    ++imu;
  }
  void on_stereo(const ums::StereoFrame& f) override {
    order_ok = order_ok && f.t_ns > last_frame && f.t_ns >= last_any;
    last_frame = f.t_ns;
    for (int y = 0; y < f.left.height; y += 5) {
      for (int x = 0; x < f.left.width; x += 3) {
        pixel_errors += f.left.row(y)[x] != pix(x, y, f.seq, 0);
        pixel_errors += f.right.row(y)[x] != pix(x, y, f.seq, 1);
      }
    }
    ++frames;
  }
  std::int64_t last_imu = -1, last_frame = -1, last_any = -1;
  std::uint64_t imu = 0, frames = 0, pixel_errors = 0;
  bool order_ok = true;
};

struct Source {
  std::vector<std::uint8_t> left = std::vector<std::uint8_t>(kW * kH), right = left;
  ums::StereoFrame frame(std::uint64_t seq, std::int64_t t_ns) {
    for (int y = 0; y < kH; ++y) {
      for (int x = 0; x < kW; ++x) {
        left[static_cast<std::size_t>(y * kW + x)] = pix(x, y, seq, 0);
        right[static_cast<std::size_t>(y * kW + x)] = pix(x, y, seq, 1);
      }
    }
    ums::StereoFrame f;
    f.t_ns = t_ns;
    f.seq = seq;
    f.left = ums::ImageView{left.data(), kW, kH, kW};
    f.right = ums::ImageView{right.data(), kW, kH, kW};
    return f;
  }
};
}  // namespace

TEST_CASE("ThreadBridge carries IMU and frames between two threads in order with exact pixels", "[d455][bridge]") {
  auto bridge = std::make_unique<ThreadBridge>(kW, kH);
  CheckingSink sink;
  std::atomic<bool> done{false};
  std::thread consumer([&] {
    while (!done.load() || bridge->pending() > 0) {
      if (bridge->drain(sink) == 0) std::this_thread::yield();
    }
  });
  Source src;
  std::uint64_t frames_sent = 0;
  for (int k = 1; k <= 4000; ++k) {  // 10 s of 400 Hz IMU, a frame every 20 samples
    ums::ImuSample s;
    s.t_ns = k * 2'500'000LL;
    s.gyro_rad_s.x() = static_cast<double>(s.t_ns);
    bridge->on_imu(s);
    if (k % 20 == 0) {
      // Back-pressure like a real camera: wait for a slot rather than measure the scheduler.
      while (bridge->pending() > 8) std::this_thread::yield();
      bridge->on_stereo(src.frame(frames_sent++, s.t_ns + 1));
    }
  }
  done = true;
  consumer.join();
  CHECK(sink.order_ok);
  CHECK(sink.imu == 4000);
  CHECK(sink.frames == 200);
  CHECK(sink.pixel_errors == 0);
  CHECK(bridge->imu_dropped() == 0);
  CHECK(bridge->frames_dropped() == 0);
}

TEST_CASE("ThreadBridge drops and counts when the consumer stalls, then recovers, without allocating", "[d455][bridge]") {
  auto bridge = std::make_unique<ThreadBridge>(kW, kH);
  Source src;
  CheckingSink sink;
  ums::AllocScope scope;
  for (int k = 0; k < 10; ++k) bridge->on_stereo(src.frame(static_cast<std::uint64_t>(k), 1000 + k));
  CHECK(bridge->frames_dropped() == 6);  // 4 slots in flight
  for (int k = 0; k < 1100; ++k) {
    ums::ImuSample s;
    s.t_ns = 2000 + k;
    s.gyro_rad_s.x() = static_cast<double>(s.t_ns);
    bridge->on_imu(s);
  }
  CHECK(bridge->imu_dropped() == 1100 - (1024 - 4));
  CHECK(bridge->drain(sink) == 1024);
  CHECK(sink.frames == 4);
  CHECK(sink.pixel_errors == 0);
  bridge->on_stereo(src.frame(99, 5000));  // slots came back
  CHECK(bridge->drain(sink) == 1);
  CHECK(sink.frames == 5);
  CHECK(scope.allocations() == 0);
}
