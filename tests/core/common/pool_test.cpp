#include "core/common/pool.hpp"

#include <catch2/catch.hpp>

#include "profiling/alloc_counter.hpp"

namespace ums {
namespace {

struct Landmark {
  int id = -1;
  double inv_depth = 0.0;
};

// Algorithms take the capacity-erased base.
int fill(IPool<Landmark>& pool, int n) {
  int got = 0;
  for (int i = 0; i < n; ++i) {
    Landmark* l = pool.acquire();
    if (l == nullptr) break;
    l->id = i;
    ++got;
  }
  return got;
}

}  // namespace

TEST_CASE("Pool hands out every slot once, refuses when empty, and reuses released slots",
          "[common]") {
  Pool<Landmark, 8> pool;
  REQUIRE(fill(pool, 10) == 8);
  REQUIRE(pool.refused() == 1);  // fill() stops at the first refusal
  REQUIRE(pool.in_use() == 8);
  REQUIRE(pool.peak() == 8);

  Landmark* third = pool.at_index(3);
  REQUIRE(third != nullptr);
  pool.release(third);
  REQUIRE(pool.in_use() == 7);
  Landmark* again = pool.acquire();
  REQUIRE(again == third);       // the freed slot comes back
  REQUIRE(again->id == -1);      // reset to a fresh object
  REQUIRE(pool.peak() == 8);
}

TEST_CASE("Pool acquire/release cycles allocate nothing", "[common][alloc]") {
  static Pool<Landmark, 256> pool;
  AllocScope scope;
  for (int round = 0; round < 100; ++round) {
    Landmark* items[256];
    for (auto& item : items) item = pool.acquire();
    for (auto* item : items) pool.release(item);
  }
  REQUIRE(scope.allocations() == 0);
  REQUIRE(pool.refused() == 0);
}

}  // namespace ums
