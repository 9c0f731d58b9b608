#include "profiling/json_writer.hpp"

#include <cmath>
#include <limits>

#include <catch2/catch.hpp>

namespace ums {

TEST_CASE("JsonWriter nests objects and arrays with commas, escapes strings, nulls non-finite",
          "[profiling]") {
  JsonWriter w(0);
  w.begin_object()
      .value("frames", 95)
      .value("ratio", 0.25)
      .value("name", "a\"b\\c\n")
      .value("nan", std::numeric_limits<double>::quiet_NaN())
      .begin_object("timing_ms")
      .begin_object("frontend")
      .value("median", 1.5)
      .end_object()
      .end_object()
      .begin_array("modes")
      .begin_object()
      .value("t", 0.0)
      .value("mode", "IMU_ONLY")
      .end_object()
      .element(2.0)
      .end_array()
      .value("ok", true)
      .end_object();
  REQUIRE(w.str() ==
          "{\"frames\":95,\"ratio\":0.25,\"name\":\"a\\\"b\\\\c\\n\",\"nan\":null,"
          "\"timing_ms\":{\"frontend\":{\"median\":1.5}},"
          "\"modes\":[{\"t\":0,\"mode\":\"IMU_ONLY\"},2],\"ok\":true}\n");
}

TEST_CASE("JsonWriter numbers read back exactly and stay short", "[profiling]") {
  JsonWriter w(0);
  w.begin_object().value("t", 1403715273.262143).value("x", 0.1).end_object();
  REQUIRE(w.str() == "{\"t\":1403715273.262143,\"x\":0.1}\n");
}

}  // namespace ums
