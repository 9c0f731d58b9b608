#include "hal/replay/euroc_reader.hpp"

#include <catch2/catch.hpp>
#include <chrono>
#include <cstdio>
#include <fstream>
#include <sstream>
#include <vector>

#include "hal/replay/euroc_writer.hpp"
#include "hal/replay/png_io.hpp"
#include "profiling/alloc_counter.hpp"
#include "tests/common/test_paths.hpp"

using ums::ImuSample;
using ums::StereoFrame;
using ums::hal::EurocReader;
using ums::hal::EurocReaderOptions;

namespace {

constexpr std::int64_t kCam0FirstNs = 1403715273262142976;
constexpr std::int64_t kCam0LastNs = 1403715277962142976;  // row 96 of cam0/data.csv
constexpr std::int64_t kImuFirstNs = 1403715273262142976;
constexpr std::int64_t kImuLastNs = 1403715418857143040;   // row 29,121 of imu0/data.csv

std::string read_text(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  std::ostringstream out;
  out << in.rdbuf();
  return out.str();
}

void write_text(const std::string& path, const std::string& text) {
  std::ofstream(path, std::ios::binary) << text;
}

// A small valid dataset: 4 stereo pairs of 32x24 px at 20 Hz, IMU at 200 Hz from the first frame.
std::string make_dataset(const std::string& name) {
  const std::string dir = ums::test::make_temp_dir(name);
  ums::RigCalibration rig;
  for (auto& cam : rig.cam) {
    cam.width = 32;
    cam.height = 24;
    cam.rate_hz = 20;
    cam.fx = cam.fy = 30;
    cam.cx = 16;
    cam.cy = 12;
  }
  rig.cam[1].T_b_c.translation() = Eigen::Vector3d(0.1, 0, 0);
  ums::hal::EurocWriter writer;
  writer.open(dir, rig);
  std::vector<std::uint8_t> px(32 * 24);
  const std::int64_t t0 = 1000000000;
  for (int i = 0; i <= 30; ++i) {
    ImuSample s;
    s.t_ns = t0 + i * 5000000;
    s.accel_m_s2 = Eigen::Vector3d(0, 0, 9.81);
    REQUIRE(writer.write_imu(s) == ums::Status::kOk);
  }
  for (int i = 0; i < 4; ++i) {
    for (std::size_t k = 0; k < px.size(); ++k) px[k] = static_cast<std::uint8_t>(k + 40 * i);
    StereoFrame f;
    f.t_ns = t0 + i * 50000000;
    f.left = ums::ImageView{px.data(), 32, 24, 32};
    f.right = f.left;
    REQUIRE(writer.write_stereo(f) == ums::Status::kOk);
  }
  writer.close();
  return dir;
}

// Runs open() and returns the exception's message ("" if none).
std::string open_error(const std::string& dir, const EurocReaderOptions& options = {}) {
  EurocReader reader;
  try {
    reader.open(dir, options);
  } catch (const std::exception& e) {
    return e.what();
  }
  return "";
}

struct StreamLog {
  std::uint64_t imu = 0, frames = 0;
  std::uint64_t imu_before_last_frame = 0;  // IMU samples streamed before the last frame
  bool imu_increasing = true;
  bool order_ok = true;            // every IMU before a frame has t <= frame t, after it t > frame t
  int min_imu_between = 1 << 30, max_imu_between = 0;
  std::int64_t first_frame = 0, last_frame = 0, first_imu = 0, last_imu = 0;
};

StreamLog stream_all(EurocReader& reader) {
  StreamLog log;
  ImuSample imu;
  StereoFrame frame;
  std::int64_t last_imu = 0, last_frame = 0;
  int between = 0;
  for (;;) {
    const EurocReader::Event e = reader.next(&imu, &frame);
    if (e == EurocReader::Event::kEnd) break;
    if (e == EurocReader::Event::kImu) {
      if (log.imu > 0 && imu.t_ns <= last_imu) log.imu_increasing = false;
      if (log.frames > 0 && imu.t_ns <= last_frame) log.order_ok = false;
      if (log.imu == 0) log.first_imu = imu.t_ns;
      last_imu = imu.t_ns;
      ++log.imu;
      ++between;
    } else {
      if (log.imu > 0 && last_imu > frame.t_ns) log.order_ok = false;
      if (log.frames == 0) log.first_frame = frame.t_ns;
      if (log.frames > 0) {
        log.min_imu_between = std::min(log.min_imu_between, between);
        log.max_imu_between = std::max(log.max_imu_between, between);
      }
      between = 0;
      last_frame = frame.t_ns;
      log.imu_before_last_frame = log.imu;
      ++log.frames;
    }
  }
  log.last_frame = last_frame;
  log.last_imu = last_imu;
  return log;
}

}  // namespace

TEST_CASE("EuRoC micro: files, calibration and summary from open()", "[euroc][real]") {
  EurocReader reader;
  reader.open(ums::test::euroc_micro_dir());
  const auto& sum = reader.summary();
  CHECK(sum.cam0_rows == 95);
  CHECK(sum.cam1_rows == 99);
  CHECK(sum.imu_rows == 29120);
  CHECK(sum.cam0_first_t_ns == kCam0FirstNs);
  CHECK(sum.cam0_last_t_ns == kCam0LastNs);
  CHECK(sum.imu_first_t_ns == kImuFirstNs);
  CHECK(sum.imu_last_t_ns == kImuLastNs);
  CHECK(reader.first_frame_t_ns() == kCam0FirstNs);
  CHECK(reader.last_frame_t_ns() == kCam0LastNs);
  CHECK(reader.total_pairs_estimate() == 95);
  CHECK_FALSE(reader.has_groundtruth());
  CHECK_THAT(reader.groundtruth_path(), Catch::EndsWith("mav0/state_groundtruth_estimate0/data.csv"));

  const ums::RigCalibration& rig = reader.calibration();
  CHECK(rig.cam[0].width == 752);
  CHECK(rig.cam[0].height == 480);
  CHECK(rig.cam[0].rate_hz == 20.0);
  CHECK(rig.cam[0].fx == 458.654);
  CHECK(rig.cam[0].fy == 457.296);
  CHECK(rig.cam[0].cx == 367.215);
  CHECK(rig.cam[1].cy == 255.238);
  CHECK(rig.cam[0].model == ums::CameraModel::kPinholeRadTan);
  CHECK(rig.cam[0].distortion[0] == -0.28340811);
  CHECK(rig.cam[1].distortion[3] == -3.55590700e-05);
  // T_BS translations are taken verbatim; the rotation is re-orthonormalized (changes < 1e-6).
  CHECK(rig.cam[0].T_b_c.translation().x() == -0.0216401454975);
  CHECK(rig.cam[1].T_b_c.translation().y() == 0.0453689425024);
  CHECK(rig.cam[0].T_b_c.linear()(0, 1) == Approx(-0.999880929698).margin(1e-6));
  // Stereo baseline of the VI-sensor: 0.110 m.
  const double baseline_m = (rig.cam[0].T_b_c.translation() - rig.cam[1].T_b_c.translation()).norm();
  CHECK(baseline_m == Approx(0.1101).margin(5e-4));
  CHECK(rig.imu.rate_hz == 200.0);
  CHECK(rig.imu.gyro_noise_density == 1.6968e-04);
  CHECK(rig.imu.gyro_random_walk == 1.9393e-05);
  CHECK(rig.imu.accel_noise_density == 2.0e-3);
  CHECK(rig.imu.accel_random_walk == 3.0e-3);
  CHECK(rig.imu.T_b_i.matrix().isIdentity(0.0));
}

// One pass over the whole micro sequence (190 PNG decodes: ~0.6 s on the host, ~10 s under qemu),
// with imu_after_last_frame so that the IMU file is streamed to its end as well.
TEST_CASE("EuRoC micro: 95 pairs, 4 unpaired right, all 29,120 IMU rows interleaved, no allocation",
          "[euroc][real][alloc]") {
  EurocReader reader;
  EurocReaderOptions options;
  options.imu_after_last_frame = true;
  reader.open(ums::test::euroc_micro_dir(), options);
  const auto start = std::chrono::steady_clock::now();
  ums::AllocScope scope;
  const StreamLog log = stream_all(reader);
  const std::uint64_t allocations = scope.allocations();
  const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();

  CHECK(log.frames == 95);
  CHECK(reader.counters().stereo_pairs == 95);
  CHECK(reader.counters().unpaired_right == 4);
  CHECK(reader.counters().unpaired_left == 0);
  CHECK(reader.counters().unreadable_images == 0);
  CHECK(reader.status() == ums::Status::kOk);
  CHECK(log.first_frame == kCam0FirstNs);
  CHECK(log.last_frame == kCam0LastNs);
  // IMU from the first to the last frame: 4.7 s at 200 Hz = 941 samples, 10 between frames;
  // then the rest of the file.
  CHECK(log.imu_before_last_frame == 941);
  CHECK(log.imu == 29120);
  CHECK(reader.counters().imu_samples == 29120);
  CHECK(log.first_imu == kImuFirstNs);
  CHECK(log.last_imu == kImuLastNs);
  CHECK(log.imu_increasing);
  CHECK(log.order_ok);
  CHECK(log.min_imu_between == 10);
  CHECK(log.max_imu_between == 10);
  if (ums::alloc_counter_available()) CHECK(allocations == 0);
  CHECK(reader.png_reader().heap_fallbacks() == 0);
  // Timing is reported, not asserted (shared machines; speed belongs to benchmarks).
  WARN("streamed 95 pairs and 29,120 IMU rows in " << seconds << " s");
}

TEST_CASE("EuRoC micro: frame pixels equal the PNG files", "[euroc][real]") {
  EurocReader reader;
  EurocReaderOptions options;
  options.duration_s = 0.01;  // the first pair only
  reader.open(ums::test::euroc_micro_dir(), options);
  ImuSample imu;
  StereoFrame frame;
  EurocReader::Event e;
  while ((e = reader.next(&imu, &frame)) == EurocReader::Event::kImu) {
  }
  REQUIRE(e == EurocReader::Event::kStereo);
  CHECK(frame.seq == 0);
  CHECK(frame.left.width == 752);
  CHECK(frame.left.stride == 752);
  std::vector<std::uint8_t> expected(752 * 480);
  int w = 0, h = 0;
  std::string error;
  REQUIRE(ums::hal::read_png_gray8(ums::test::euroc_micro_dir() + "/mav0/cam1/data/1403715273262142976.png",
                                   expected.data(), expected.size(), &w, &h, &error));
  CHECK(std::equal(expected.begin(), expected.end(), frame.right.data));
  CHECK_FALSE(std::equal(expected.begin(), expected.end(), frame.left.data));  // left differs
  CHECK(reader.next(&imu, &frame) == EurocReader::Event::kEnd);
}

TEST_CASE("EuRoC micro: start and duration select a window of frames and IMU", "[euroc][real]") {
  EurocReader reader;
  EurocReaderOptions options;
  options.start_s = 0.99;
  options.duration_s = 1.0;  // frames 20..39 (t0 + 1.00 s .. t0 + 1.95 s)
  reader.open(ums::test::euroc_micro_dir(), options);
  CHECK(reader.total_pairs_estimate() == 20);
  const StreamLog log = stream_all(reader);
  CHECK(log.frames == 20);
  CHECK((log.first_frame - kCam0FirstNs) == Approx(1.0e9).margin(1e3));
  CHECK((log.last_frame - kCam0FirstNs) == Approx(1.95e9).margin(1e3));
  // IMU from 0.1 s (imu_lead_s) before the window start (t0 + 0.89 s) to the last frame (t0 + 1.95 s).
  CHECK((log.first_imu - kCam0FirstNs) == Approx(0.89e9).margin(5e6));
  CHECK(log.imu == 213);
  CHECK(log.imu_before_last_frame == 213);  // without imu_after_last_frame the IMU stops there
  CHECK(reader.counters().unpaired_right == 0);  // the unpaired right rows lie outside the window
  CHECK(log.order_ok);
}

TEST_CASE("EuRoC reader options are validated", "[euroc]") {
  const std::string dir = make_dataset("euroc_options");
  EurocReaderOptions options;
  options.start_s = -1;
  CHECK_THAT(open_error(dir, options), Catch::Contains("start_s") && Catch::Contains("-1"));
  options.start_s = 5.0;  // the sequence spans 0.15 s
  CHECK_THAT(open_error(dir, options), Catch::Contains("after the last frame"));
  options = {};
  options.duration_s = -2;
  CHECK_THAT(open_error(dir, options), Catch::Contains("duration_s"));
  options = {};
  options.pair_tolerance_ns = -1;
  CHECK_THAT(open_error(dir, options), Catch::Contains("pair_tolerance_ns"));
  options = {};
  options.imu_lead_s = 11;
  CHECK_THAT(open_error(dir, options), Catch::Contains("imu_lead_s must be in 0..10 s"));
}

TEST_CASE("EuRoC reader: missing folders and files are named", "[euroc][malformed]") {
  const std::string dir = make_dataset("euroc_missing");
  CHECK(open_error(dir).empty());
  {
    EurocReader reader;  // a failed open leaves nothing to stream
    CHECK_THROWS(reader.open(dir + "/nope"));
    ImuSample imu;
    StereoFrame frame;
    CHECK(reader.next(&imu, &frame) == EurocReader::Event::kEnd);
  }
  CHECK_THAT(open_error(dir + "/nope"), Catch::Contains("/nope: no such folder"));
  const std::string empty = ums::test::make_temp_dir("euroc_missing_empty");
  CHECK_THAT(open_error(empty), Catch::Contains("no mav0/ folder"));
  std::remove((dir + "/mav0/cam1/data.csv").c_str());
  CHECK_THAT(open_error(dir), Catch::Contains("mav0/cam1/data.csv: cannot open"));
  std::remove((dir + "/mav0/imu0/sensor.yaml").c_str());
  CHECK_THAT(open_error(dir), Catch::Contains("mav0/imu0/sensor.yaml: cannot open"));
}

TEST_CASE("EuRoC reader: malformed CSV rows are named by file and line", "[euroc][malformed]") {
  const std::string dir = make_dataset("euroc_rows");
  const std::string cam0 = dir + "/mav0/cam0/data.csv";
  const std::string imu0 = dir + "/mav0/imu0/data.csv";
  const std::string cam0_text = read_text(cam0);
  const std::string imu0_text = read_text(imu0);

  SECTION("wrong column count") {
    write_text(cam0, "#timestamp [ns],filename\n1000000000,1000000000.png\n1050000000,1050000000.png,extra\n");
    CHECK_THAT(open_error(dir), Catch::Contains("cam0/data.csv:3: expected 2 columns") && Catch::Contains("found 3"));
  }
  SECTION("non-numeric timestamp") {
    write_text(cam0, "#timestamp [ns],filename\n1000000000,1000000000.png\n10500x0000,1050000000.png\n");
    CHECK_THAT(open_error(dir), Catch::Contains("cam0/data.csv:3: timestamp '10500x0000' is not an integer"));
  }
  SECTION("duplicate timestamp") {
    write_text(cam0, "#timestamp [ns],filename\n1000000000,a.png\n1000000000,b.png\n");
    CHECK_THAT(open_error(dir), Catch::Contains("cam0/data.csv:3: duplicate timestamp 1000000000 (also on line 2)"));
  }
  SECTION("non-monotonic timestamps") {
    write_text(cam0, "#timestamp [ns],filename\n1050000000,a.png\n\n1000000000,b.png\n");
    CHECK_THAT(open_error(dir), Catch::Contains("cam0/data.csv:4: timestamp 1000000000 is earlier than 1050000000 on line 2"));
  }
  SECTION("IMU row with a non-numeric value") {
    std::string text = imu0_text;
    const std::size_t row3 = text.find('\n', text.find('\n', text.find('\n') + 1) + 1) + 1;  // line 4
    text.insert(text.find(',', text.find(',', row3) + 1) + 1, "x");
    write_text(imu0, text);
    CHECK_THAT(open_error(dir), Catch::Contains("imu0/data.csv:4: column 2 ('x"));
  }
  SECTION("IMU row with 6 columns") {
    write_text(imu0, "#t,w,w,w,a,a,a\n1000000000,0,0,0,0,0,9.8\n1005000000,0,0,0,0,0\n");
    CHECK_THAT(open_error(dir), Catch::Contains("imu0/data.csv:3: expected 7 columns") && Catch::Contains("found 6"));
  }
  SECTION("IMU with NaN") {
    write_text(imu0, "1000000000,0,0,0,0,0,nan\n");
    CHECK_THAT(open_error(dir), Catch::Contains("imu0/data.csv:1: column 6 ('nan') is not a finite number"));
  }
  SECTION("empty data.csv") {
    write_text(cam0, "#timestamp [ns],filename\n");
    CHECK_THAT(open_error(dir), Catch::Contains("cam0/data.csv: no data rows"));
  }
  SECTION("CRLF, comments, blank lines and spaces are tolerated") {
    std::string crlf = "\xEF\xBB\xBF# converted on Windows\r\n";
    for (char c : cam0_text) crlf += c == '\n' ? std::string("\r\n\r\n") : std::string(1, c);
    write_text(cam0, crlf);
    std::string spaced;
    for (char c : imu0_text) spaced += c == ',' ? std::string(", ") : std::string(1, c);
    write_text(imu0, "\n# IMU\n" + spaced);
    EurocReader reader;
    REQUIRE_NOTHROW(reader.open(dir));
    const StreamLog log = stream_all(reader);
    CHECK(log.frames == 4);
    CHECK(log.imu == 31);
    CHECK(reader.summary().imu_rows == 31);
  }
}

TEST_CASE("EuRoC reader: image size differing from sensor.yaml fails at open with file and line",
          "[euroc][malformed]") {
  const std::string dir = make_dataset("euroc_size");
  std::vector<std::uint8_t> px(16 * 8, 7);
  std::string error;
  REQUIRE(ums::hal::write_png_gray8(dir + "/mav0/cam1/data/1100000000.png", ums::ImageView{px.data(), 16, 8, 16}, &error));
  CHECK_THAT(open_error(dir), Catch::Contains("cam1/data.csv:4: image 1100000000.png is 16x8") &&
                                  Catch::Contains("cam1/sensor.yaml has resolution [32, 24]"));
}

TEST_CASE("EuRoC reader: unreadable or missing PNGs skip their pair and are counted", "[euroc][malformed]") {
  const std::string dir = make_dataset("euroc_unreadable");
  write_text(dir + "/mav0/cam0/data/1050000000.png", "not a png");
  std::remove((dir + "/mav0/cam1/data/1150000000.png").c_str());
  EurocReader reader;
  reader.open(dir);
  const StreamLog log = stream_all(reader);
  CHECK(log.frames == 2);
  CHECK(reader.counters().unreadable_images == 2);
  CHECK(reader.counters().stereo_pairs == 2);
  CHECK(reader.status() == ums::Status::kOk);
  CHECK_THAT(std::string(reader.last_image_error()), Catch::Contains("1150000000.png: cannot open") &&
                                                         Catch::Contains("cam1/data.csv line 5"));
  CHECK(log.imu == 31);  // the IMU stream continues across skipped frames
}

TEST_CASE("EuRoC reader: unpaired rows and a pairing tolerance", "[euroc]") {
  const std::string dir = make_dataset("euroc_pairs");
  // cam1 rows shifted by 1 us except the first: exact pairing keeps 1 pair, 1 us tolerance all 4.
  write_text(dir + "/mav0/cam1/data.csv",
             "#timestamp [ns],filename\n1000000000,1000000000.png\n1050001000,1050000000.png\n"
             "1100001000,1100000000.png\n1150001000,1150000000.png\n");
  EurocReader reader;
  reader.open(dir);
  StreamLog log = stream_all(reader);
  CHECK(log.frames == 1);
  CHECK(reader.counters().unpaired_left == 3);
  CHECK(reader.counters().unpaired_right == 3);
  EurocReaderOptions options;
  options.pair_tolerance_ns = 1000;
  reader.open(dir, options);
  log = stream_all(reader);
  CHECK(log.frames == 4);
  CHECK(log.last_frame == 1150000000);  // the pair takes cam0's time
  CHECK(reader.counters().unpaired_left + reader.counters().unpaired_right == 0);
}

TEST_CASE("EuRoC reader: a broken sensor.yaml names the file and key", "[euroc][malformed]") {
  const std::string dir = make_dataset("euroc_yaml");
  const std::string yaml = dir + "/mav0/cam0/sensor.yaml";
  const std::string good = read_text(yaml);
  SECTION("missing key") {
    std::string text = good;
    text.replace(text.find("intrinsics"), 10, "intrinsicz");
    write_text(yaml, text);
    CHECK_THAT(open_error(dir), Catch::Contains("cam0/sensor.yaml: key 'intrinsics': missing"));
  }
  SECTION("resolution beyond capacity") {
    std::string text = good;
    text.replace(text.find("[32, 24]"), 8, "[4000, 24]");
    write_text(yaml, text);
    CHECK_THAT(open_error(dir), Catch::Contains("cam0/sensor.yaml: key 'resolution'") && Catch::Contains("4000") &&
                                    Catch::Contains("1..1280"));
  }
  SECTION("syntax error") {
    std::string text = good;
    text.replace(text.find("[32, 24]"), 8, "[32, 24");
    write_text(yaml, text);
    CHECK_THAT(open_error(dir), Catch::Contains("cam0/sensor.yaml:") && Catch::Contains("YAML syntax error"));
  }
  SECTION("no %YAML directive is accepted") {
    write_text(yaml, good.substr(good.find('\n') + 1));
    CHECK(open_error(dir).empty());
  }
}
