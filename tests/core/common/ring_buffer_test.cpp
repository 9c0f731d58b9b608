#include "core/common/ring_buffer.hpp"

#include <catch2/catch.hpp>

namespace ums {

TEST_CASE("RingBuffer is FIFO across wrap-around", "[common]") {
  RingBuffer<int, 4> ring;
  int out = -1;
  for (int i = 0; i < 4; ++i) REQUIRE(ring.push(i) == Status::kOk);
  REQUIRE(ring.push(99) == Status::kFull);
  REQUIRE(ring.pop(&out) == Status::kOk);
  REQUIRE(out == 0);
  REQUIRE(ring.push(4) == Status::kOk);  // wraps
  REQUIRE(ring.front() == 1);
  REQUIRE(ring.back() == 4);
  for (int expected = 1; expected <= 4; ++expected) {
    REQUIRE(ring.pop(&out) == Status::kOk);
    REQUIRE(out == expected);
  }
  REQUIRE(ring.pop(&out) == Status::kEmpty);
}

}  // namespace ums
