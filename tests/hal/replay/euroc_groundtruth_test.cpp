#include "hal/replay/euroc_groundtruth.hpp"

#include <catch2/catch.hpp>
#include <fstream>

#include "tests/common/test_paths.hpp"

using ums::hal::CsvReader;

TEST_CASE("ground-truth reader parses EuRoC rows and names bad ones", "[euroc][groundtruth]") {
  const std::string dir = ums::test::make_temp_dir("groundtruth_reader");
  const std::string path = dir + "/data.csv";
  std::ofstream(path) << ums::hal::kEurocGroundtruthHeader << "\r\n"
                      << "1403715273262142976,0.878612,2.142470,0.947262,0.060514,-0.828459,-0.058956,-0.553641,"
                         "0.009474,-0.014009,-0.002145,-0.002229,0.020700,0.076350,-0.012492,0.547666,0.069073\r\n"
                      << "1403715273267142912,0.878620,2.142469,0.947262,0.060514,-0.828459,-0.058956,-0.553641,"
                         "0.009474,-0.014009,-0.002145,-0.002229,0.020700,0.076350,-0.012492,0.547666,0.069073\n"
                      << "1403715273267142912,0.878620,2.142469,0.947262,1,0,0,0,0,0,0,0,0,0,0,0,0\n";
  ums::hal::EurocGroundtruthReader reader;
  reader.open(path);
  ums::hal::GroundTruthState s;
  REQUIRE(reader.next(&s) == CsvReader::Result::kRow);
  CHECK(s.t_ns == 1403715273262142976);
  CHECK(s.p_w_b.x() == 0.878612);
  CHECK(s.q_w_b.w() == Approx(0.060514).epsilon(1e-5));   // file order w, x, y, z
  CHECK(s.q_w_b.x() == Approx(-0.828459).epsilon(1e-5));
  CHECK(s.v_w_b.x() == 0.009474);
  CHECK(s.gyro_bias_rad_s.z() == 0.076350);
  CHECK(s.accel_bias_m_s2.y() == 0.547666);
  REQUIRE(reader.next(&s) == CsvReader::Result::kRow);
  REQUIRE(reader.next(&s) == CsvReader::Result::kError);
  CHECK_THAT(std::string(reader.error()), Catch::Contains("data.csv:4: timestamp 1403715273267142912 is not after"));

  std::ofstream(path) << "1,0,0,0,2,0,0,0,0,0,0,0,0,0,0,0,0\n1,2,3\n";
  reader.open(path);
  REQUIRE(reader.next(&s) == CsvReader::Result::kError);
  CHECK_THAT(std::string(reader.error()), Catch::Contains("data.csv:1: quaternion norm 2.000000 is not 1"));
  reader.open(path);
  std::ofstream(path) << "1,2,3\n";
  reader.open(path);
  REQUIRE(reader.next(&s) == CsvReader::Result::kError);
  CHECK_THAT(std::string(reader.error()), Catch::Contains("data.csv:1: expected 17 columns"));
}
