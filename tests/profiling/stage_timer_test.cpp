#include "profiling/stage_timer.hpp"

#include <catch2/catch.hpp>

#include "profiling/alloc_counter.hpp"

namespace ums {

TEST_CASE("StageTimes gives median, p99 and max of recorded durations", "[profiling]") {
  static StageTimes times;  // large: keep it off the stack
  for (int i = 1; i <= 100; ++i) times.record(Stage::kFrontend, static_cast<double>(i));
  const StageSummary s = times.summary(Stage::kFrontend);
  REQUIRE(s.count == 100);
  REQUIRE(s.median_ms == Approx(51.0).margin(1.0));
  REQUIRE(s.p99_ms == Approx(99.0).margin(1.0));
  REQUIRE(s.max_ms == 100.0);
  REQUIRE(s.mean_ms == Approx(50.5));
  REQUIRE(times.summary(Stage::kBackend).count == 0);
}

TEST_CASE("StageTimes keeps the max of the whole run beyond its window, records without allocating",
          "[profiling][alloc]") {
  static StageTimes times;
  times.record(Stage::kTotal, 1000.0);
  AllocScope scope;
  for (std::size_t i = 0; i < 2 * StageTimes::kWindow; ++i) {
    ScopedStageTimer t(&times, Stage::kTotal);
  }
  REQUIRE(scope.allocations() == 0);
  const StageSummary s = times.summary(Stage::kTotal);
  REQUIRE(s.count == 2 * StageTimes::kWindow + 1);
  REQUIRE(s.max_ms == 1000.0);
  REQUIRE(s.median_ms < 1.0);  // the window holds only the fast samples now
}

}  // namespace ums
