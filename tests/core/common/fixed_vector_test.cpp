#include "core/common/fixed_vector.hpp"

#include <catch2/catch.hpp>

#include "profiling/alloc_counter.hpp"

namespace ums {

TEST_CASE("FixedVector refuses the element past capacity and keeps the rest", "[common]") {
  FixedVector<int, 3> v;
  REQUIRE(v.push_back(1) == Status::kOk);
  REQUIRE(v.push_back(2) == Status::kOk);
  REQUIRE(v.push_back(3) == Status::kOk);
  REQUIRE(v.push_back(4) == Status::kFull);
  REQUIRE(v.size() == 3);
  REQUIRE(v[2] == 3);
  v.swap_remove(0);
  REQUIRE(v.size() == 2);
  REQUIRE(v[0] == 3);
  REQUIRE(v[1] == 2);
  REQUIRE(v.resize(4) == Status::kFull);
}

TEST_CASE("FixedVector push and clear allocate nothing", "[common][alloc]") {
  FixedVector<double, 1000> v;
  AllocScope scope;
  for (int round = 0; round < 10; ++round) {
    v.clear();
    for (int i = 0; i < 1000; ++i) REQUIRE(v.push_back(i * 0.5) == Status::kOk);
  }
  REQUIRE(scope.allocations() == 0);
}

}  // namespace ums
