#include "hal/d455/time_base.hpp"

#include <catch2/catch.hpp>

using namespace ums::d455;

TEST_CASE("Unwrap32 carries the device µs counter across its 2^32 wrap and keeps small steps back", "[d455][time]") {
  Unwrap32 u;
  const std::uint32_t near_end = 0xFFFFFF00u;
  CHECK(u.unwrap(near_end) == 0xFFFFFF00LL);
  CHECK(u.unwrap(0x00000010u) == 0x100000010LL);        // wrapped: +0x110 µs
  CHECK(u.unwrap(0xFFFFFFF0u) == 0xFFFFFFF0LL);         // a late sample from before the wrap
  CHECK(u.unwrap(0x00000020u) == 0x100000020LL);        // epoch kept
  // Two wraps later (71.6 min each), fed every ~1000 s, still monotonic.
  std::int64_t last = 0x100000020LL;
  std::uint32_t raw = 0x20u;
  for (int i = 0; i < 10; ++i) {
    raw += 1000000000u;
    const std::int64_t v = u.unwrap(raw);
    CHECK(v - last == 1000000000LL);
    last = v;
  }
}

TEST_CASE("DeviceClockMap takes the lower envelope of host - device and follows a slow device clock", "[d455][time]") {
  ClockMapOptions o;
  o.max_drift_ppm = 100.0;
  DeviceClockMap m(o);
  const std::int64_t offset = 5'000'000'000LL;  // host = device + 5 s (+ latency)
  // Latencies 3 ms, 1 ms, 2 ms: the minimum (1 ms) wins.
  m.observe(0, offset + 3'000'000);
  m.observe(10'000'000, offset + 10'000'000 + 1'000'000);
  m.observe(20'000'000, offset + 20'000'000 + 2'000'000);
  // The estimate may have leaked up by at most 100 ppm x 20 ms = 2 µs since the 1 ms sample.
  CHECK(std::llabs(m.offset_ns() - (offset + 1'000'000)) <= 2'000);
  CHECK(m.to_host_ns(100'000'000) - (100'000'000 + offset) == Approx(1'000'000).margin(2'000));
  // Device clock 50 ppm slow: the true offset grows 50 µs/s; with 100 ppm leak the error stays
  // bounded by one latency (1 ms) over 60 s.
  for (int k = 1; k <= 600; ++k) {
    const std::int64_t host = offset + k * 100'000'000LL;
    const std::int64_t device = static_cast<std::int64_t>(static_cast<double>(k * 100'000'000LL) * (1.0 - 50e-6));
    m.observe(device, host + 1'000'000);
  }
  const std::int64_t device_now = static_cast<std::int64_t>(60e9 * (1.0 - 50e-6));
  CHECK(std::llabs(m.to_host_ns(device_now) - (offset + 60'000'000'000LL)) < 1'100'000);
}

TEST_CASE("OrderGate passes increasing stamps and counts duplicates and steps back", "[d455][time]") {
  OrderGate g;
  CHECK(g.accept(10));
  CHECK(g.accept(20));
  CHECK_FALSE(g.accept(20));
  CHECK_FALSE(g.accept(15));
  CHECK(g.accept(30));
  CHECK(g.duplicates() == 1);
  CHECK(g.out_of_order() == 1);
  CHECK(g.last_ns() == 30);
}
