#include "profiling/alloc_counter.hpp"

#include <cstdlib>
#include <memory>
#include <thread>
#include <vector>

#include <catch2/catch.hpp>

namespace ums {

// Sanitizer builds (UMS_SANITIZE) compile the hooks out: the counter then says so and counts
// nothing, which is what the "no allocation" checks elsewhere rely on (they check only when
// alloc_counter_available()).
TEST_CASE("Without the hooks the counter says it is unavailable and counts nothing", "[profiling][alloc]") {
  if (alloc_counter_available()) return;  // the hooked build: the tests below
  AllocScope scope;
  auto p = std::make_unique<double[]>(100);
  std::thread worker([] { std::vector<int> v(1000, 1); });
  worker.join();
  REQUIRE(p != nullptr);
  REQUIRE(scope.allocations() == 0);
  REQUIRE(scope.bytes() == 0);
  REQUIRE(scope.deallocations() == 0);
  REQUIRE(process_allocations() == 0);
}

TEST_CASE("AllocScope counts operator new, malloc and container growth", "[profiling][alloc]") {
  if (!alloc_counter_available()) return;  // hooks compiled out (sanitizer build)
  AllocScope scope;
  auto p = std::make_unique<double[]>(100);
  void* m = std::malloc(64);
  std::vector<int> v;
  for (int i = 0; i < 100; ++i) v.push_back(i);
  std::free(m);
  // make_unique (1), malloc (1) and at least 7 vector regrowths (1, 2, 4, ... 128).
  REQUIRE(scope.allocations() >= 9);
  REQUIRE(scope.bytes() >= 100 * sizeof(double) + 64 + 100 * sizeof(int));
  REQUIRE(scope.deallocations() >= 1);
}

TEST_CASE("AllocScope sees zero for code that only uses the stack", "[profiling][alloc]") {
  AllocScope scope;
  double acc = 0.0;
  double buffer[256];
  for (int i = 0; i < 256; ++i) buffer[i] = i * 0.25;
  for (double b : buffer) acc += b;
  REQUIRE(acc == Approx(8160.0));
  REQUIRE(scope.allocations() == 0);
}

TEST_CASE("AllocScope counts only its own thread", "[profiling][alloc]") {
  if (!alloc_counter_available()) return;  // hooks compiled out (sanitizer build)
  AllocScope scope;
  std::uint64_t other_thread_allocs = 0;
  std::thread worker([&other_thread_allocs] {
    AllocScope inner;
    std::vector<int> v(1000, 1);
    other_thread_allocs = inner.allocations();
  });
  const std::uint64_t after_spawn = scope.allocations();  // std::thread's own state
  worker.join();
  REQUIRE(other_thread_allocs >= 1);
  REQUIRE(scope.allocations() == after_spawn);
  REQUIRE(process_allocations() >= other_thread_allocs);
}

}  // namespace ums
