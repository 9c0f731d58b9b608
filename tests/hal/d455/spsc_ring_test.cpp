#include "hal/d455/spsc_ring.hpp"

#include <catch2/catch.hpp>

#include <thread>

#include "profiling/alloc_counter.hpp"

using ums::Status;
using ums::d455::SpscRing;

TEST_CASE("SpscRing keeps FIFO order across two threads with no loss when the consumer keeps up", "[d455][spsc]") {
  SpscRing<std::uint64_t, 256> ring;
  constexpr std::uint64_t kItems = 200000;
  std::uint64_t received = 0, out_of_order = 0, sum = 0;
  std::thread consumer([&] {
    std::uint64_t expect = 0, v = 0;
    while (received < kItems) {
      if (ring.pop(&v) == Status::kOk) {
        out_of_order += v != expect;
        expect = v + 1;
        sum += v;
        ++received;
      } else {
        std::this_thread::yield();
      }
    }
  });
  std::uint64_t i = 0;
  while (i < kItems) {  // a producer that retries instead of dropping, to check integrity
    if (ring.push(i) == Status::kOk) ++i;
    else std::this_thread::yield();
  }
  consumer.join();
  CHECK(received == kItems);
  CHECK(out_of_order == 0);
  CHECK(sum == kItems * (kItems - 1) / 2);
  CHECK(ring.size() == 0);
}

TEST_CASE("SpscRing drops and counts pushes on a full ring, allocation-free", "[d455][spsc]") {
  SpscRing<int, 8> ring;
  ums::AllocScope scope;
  int accepted = 0;
  for (int k = 0; k < 20; ++k) accepted += ring.push(k) == Status::kOk;
  CHECK(accepted == 8);
  CHECK(ring.overflows() == 12);
  int v = -1;
  REQUIRE(ring.pop(&v) == Status::kOk);
  CHECK(v == 0);  // the oldest survives, the newest were dropped
  CHECK(ring.push(100) == Status::kOk);
  for (int k = 1; k < 8; ++k) {
    REQUIRE(ring.pop(&v) == Status::kOk);
    CHECK(v == k);
  }
  REQUIRE(ring.pop(&v) == Status::kOk);
  CHECK(v == 100);
  CHECK(ring.pop(&v) == Status::kEmpty);
  CHECK(scope.allocations() == 0);
}
