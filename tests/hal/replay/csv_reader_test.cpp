#include "hal/replay/csv_reader.hpp"

#include <catch2/catch.hpp>
#include <fstream>
#include <string>

#include "profiling/alloc_counter.hpp"
#include "tests/common/test_paths.hpp"

using ums::hal::CsvReader;

TEST_CASE("CsvReader splits rows, skips comments and blank lines, counts lines", "[csv]") {
  const std::string path = ums::test::make_temp_dir("csv_basic") + "/a.csv";
  std::ofstream(path, std::ios::binary) << "# header\r\n\r\n 1 , 2.5,abc \r\n   \n#x\n-7,+3,\n4";  // no final newline
  CsvReader csv;
  csv.open(path);
  REQUIRE(csv.next() == CsvReader::Result::kRow);
  CHECK(csv.line() == 3);
  REQUIRE(csv.field_count() == 3);
  CHECK(std::string(csv.field(2)) == "abc");
  std::int64_t i = 0;
  double d = 0;
  CHECK(csv.field_int64(0, &i));
  CHECK(i == 1);
  CHECK(csv.field_double(1, &d));
  CHECK(d == 2.5);
  CHECK_FALSE(csv.field_int64(1, &i));  // "2.5" is not an integer
  CHECK_FALSE(csv.field_double(2, &d));
  REQUIRE(csv.next() == CsvReader::Result::kRow);
  CHECK(csv.line() == 6);
  REQUIRE(csv.field_count() == 3);
  CHECK(csv.field_int64(0, &i));
  CHECK(i == -7);
  CHECK(csv.field_int64(1, &i));
  CHECK(i == 3);
  CHECK(std::string(csv.field(2)).empty());
  REQUIRE(csv.next() == CsvReader::Result::kRow);
  CHECK(csv.line() == 7);
  CHECK(std::string(csv.field(0)) == "4");
  CHECK(csv.next() == CsvReader::Result::kEnd);
  CHECK(csv.next() == CsvReader::Result::kEnd);
}

TEST_CASE("CsvReader reads rows across buffer refills without allocating", "[csv][alloc]") {
  const std::string path = ums::test::make_temp_dir("csv_refill") + "/big.csv";
  const int rows = 20000;  // ~0.5 MB: several 64 KiB refills with lines cut at the boundary
  {
    std::ofstream out(path);
    for (int r = 0; r < rows; ++r) out << 1000000000LL + r << ",0.125,-3.5e-3," << r * 0.5 << "\n";
  }
  CsvReader csv;
  csv.open(path);
  ums::AllocScope scope;
  int count = 0;
  bool ok = true;
  CsvReader::Result result;
  while ((result = csv.next()) == CsvReader::Result::kRow) {
    std::int64_t t = 0;
    double v = 0;
    ok = ok && csv.field_count() == 4 && csv.field_int64(0, &t) && t == 1000000000LL + count &&
         csv.field_double(3, &v) && v == count * 0.5 && csv.line() == count + 1;
    ++count;
  }
  if (ums::alloc_counter_available()) CHECK(scope.allocations() == 0);
  CHECK(result == CsvReader::Result::kEnd);
  CHECK(count == rows);
  CHECK(ok);
}

TEST_CASE("CsvReader errors name file and line", "[csv]") {
  const std::string dir = ums::test::make_temp_dir("csv_errors");
  CsvReader csv;
  CHECK_THROWS_WITH(csv.open(dir + "/none.csv"), Catch::Contains("none.csv: cannot open"));
  {
    std::ofstream out(dir + "/long.csv");
    out << "1,2\n" << std::string(CsvReader::kBufferBytes + 10, '9') << "\n";
  }
  csv.open(dir + "/long.csv");
  CHECK(csv.next() == CsvReader::Result::kRow);
  CHECK(csv.next() == CsvReader::Result::kError);
  CHECK_THAT(std::string(csv.error()), Catch::Contains("long.csv:2: line longer than"));
  {
    std::ofstream out(dir + "/wide.csv");
    out << std::string(40, ',') << "\n";
  }
  csv.open(dir + "/wide.csv");
  CHECK(csv.next() == CsvReader::Result::kError);
  CHECK_THAT(std::string(csv.error()), Catch::Contains("wide.csv:1: more than 32 columns"));
}
