#include "profiling/eval/mode_timeline.hpp"

#include <catch2/catch.hpp>

using namespace ums::eval;

// The keys as flatten_json gives them for a stats.json of this branch's replay.
TEST_CASE("mode timeline from stats.json keys, with exact stamps", "[eval][modes]") {
  const std::map<std::string, std::string> stats = {
      {"first_frame_t_ns", "1403636580863555584"},
      {"modes.0.t_s", "0.05"},     {"modes.0.t_ns", "1403636580913555584"},
      {"modes.0.from", "IMU_ONLY"}, {"modes.0.to", "VO"},
      {"modes.1.t_s", "7.7"},      {"modes.1.t_ns", "1403636588563555584"},
      {"modes.1.from", "VO"},       {"modes.1.to", "VIO"},
      {"estimator.mode", "VIO"}};
  ModeTimeline t;
  std::string err;
  REQUIRE(mode_timeline_from_stats(stats, &t, &err));
  CHECK(t.origin_known);
  CHECK(t.origin_t_ns == 1403636580863555584LL);
  CHECK(t.initial_mode == "IMU_ONLY");
  REQUIRE(t.changes.size() == 2);
  CHECK(t.changes[0].since_origin_ns == 50'000'000LL);
  CHECK(t.changes[1].since_origin_ns == 7'700'000'000LL);
  // A pose stamped at a change counts in the new mode.
  CHECK(t.mode_at(0) == "IMU_ONLY");
  CHECK(t.mode_at(49'999'999LL) == "IMU_ONLY");
  CHECK(t.mode_at(50'000'000LL) == "VO");
  CHECK(t.mode_at(7'699'999'999LL) == "VO");
  CHECK(t.mode_at(7'700'000'000LL) == "VIO");
}

TEST_CASE("mode timeline from an older stats.json (t_s only) and from a run without changes",
          "[eval][modes]") {
  ModeTimeline t;
  std::string err;
  // t_s has 4 significant digits: 123.46 s is written 123.5.
  REQUIRE(mode_timeline_from_stats({{"modes.0.t_s", "123.5"}, {"modes.0.from", "VIO"}, {"modes.0.to", "IMU_ONLY"}},
                                   &t, &err));
  CHECK_FALSE(t.origin_known);
  CHECK(t.initial_mode == "VIO");
  REQUIRE(t.changes.size() == 1);
  CHECK(t.changes[0].since_origin_ns == 123'500'000'000LL);

  REQUIRE(mode_timeline_from_stats({{"estimator.mode", "VO"}}, &t, &err));
  CHECK(t.changes.empty());
  CHECK(t.mode_at(1'000'000'000'000LL) == "VO");

  CHECK_FALSE(mode_timeline_from_stats({{"frames", "41"}}, &t, &err));
  CHECK(err.find("no mode timeline") != std::string::npos);
  CHECK_FALSE(mode_timeline_from_stats({{"modes.0.t_s", "soon"}, {"modes.0.to", "VO"}}, &t, &err));
  CHECK(err.find("modes.0.t_s") != std::string::npos);
  CHECK_FALSE(mode_timeline_from_stats({{"first_frame_t_ns", "1.5e9"}, {"estimator.mode", "VO"}}, &t, &err));
}
