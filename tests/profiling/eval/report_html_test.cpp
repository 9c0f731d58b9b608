#include "profiling/eval/report_html.hpp"

#include <catch2/catch.hpp>

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <vector>
#include <filesystem>
#include <fstream>
#include <string>

#include <png.h>

#include "tests/common/test_paths.hpp"

using namespace ums::eval;

namespace {

ReportData example_report() {
  ReportData d;
  d.title = "report test";
  d.summary = {{"dataset", "synthetic"}, {"ATE rmse", "0.05 m"}};
  for (int i = 0; i < 400; ++i) {
    const double t = 0.05 * i;
    const Eigen::Vector3d p(2.0 * std::cos(0.3 * t), 1.5 * std::sin(0.3 * t), 1.0 + 0.2 * std::sin(t));
    d.groundtruth.t_s.push_back(t);
    d.groundtruth.p_w_m.push_back(p);
    d.estimate.t_s.push_back(t);
    d.estimate.p_w_m.push_back(p + Eigen::Vector3d(0.05 * std::sin(0.5 * t), 0.03, 0.0));
    d.error_t_s.push_back(t);
    d.error_m.push_back(std::hypot(0.05 * std::sin(0.5 * t), 0.03));
    d.features.t_s.push_back(t);
    d.features.n_3d.push_back(80 + (i % 17));
    d.features.n_2d_left.push_back(30 + (i % 7));
    d.features.n_2d_right.push_back(10 + (i % 5));
  }
  d.stage_timings.push_back({"frontend", {}});
  d.stage_timings.push_back({"backend", {}});
  for (int i = 0; i < 400; ++i) {
    d.stage_timings[0].ms.push_back(8.0 + (i % 13) * 0.4);
    d.stage_timings[1].ms.push_back(15.0 + (i % 29) * 0.7);
  }
  d.modes = {{0.0, "IMU_ONLY"}, {1.5, "VO"}, {3.0, "VIO"}};
  d.end_t_s = 20.0;
  return d;
}

// Fraction of pixels that are not near-white in an 8-bit RGB(A)/grey PNG; -1 on read failure.
[[maybe_unused]] double non_white_fraction(const std::string& path) {
  png_image img;
  std::memset(&img, 0, sizeof img);
  img.version = PNG_IMAGE_VERSION;
  if (png_image_begin_read_from_file(&img, path.c_str()) == 0) return -1.0;
  img.format = PNG_FORMAT_RGB;
  std::vector<unsigned char> buf(PNG_IMAGE_SIZE(img));
  if (png_image_finish_read(&img, nullptr, buf.data(), 0, nullptr) == 0) return -1.0;
  std::size_t dark = 0;
  const std::size_t n = static_cast<std::size_t>(img.width) * img.height;
  for (std::size_t i = 0; i < n; ++i) {
    if (buf[3 * i] < 200 || buf[3 * i + 1] < 200 || buf[3 * i + 2] < 200) ++dark;
  }
  return static_cast<double>(dark) / static_cast<double>(n);
}

}  // namespace

TEST_CASE("report.html is one self-contained document with every section", "[eval][report]") {
  const std::string html = render_report_html(example_report());
  CHECK(html.find("<svg") != std::string::npos);
  for (const char* s : {"Top view", "Position error over time", "x over time", "z over time", "frontend [ms]",
                        "Features per frame by class", "Mode timeline", "VIO", "3D (stereo)", "2D right"}) {
    INFO(s);
    CHECK(html.find(s) != std::string::npos);
  }
  // Self-contained: no external resource of any kind.
  CHECK(html.find("http://") == html.find("http://www.w3.org/2000/svg"));
  CHECK(html.find("https://") == std::string::npos);
  CHECK(html.find("<script") == std::string::npos);
  CHECK(html.find("src=") == std::string::npos);
  CHECK(html.find("nan") == std::string::npos);
}

// Loop closure: the map-frame trajectory and one line per accepted loop on the top view (from the
// query keyframe to the loop keyframe), and the loops' table; no section without loops.
TEST_CASE("report.html draws the loops on the top view and lists them", "[eval][report][loop]") {
  ReportData d = example_report();
  const std::string without = render_report_html(d);
  CHECK(without.find("<h2>Loops</h2>") == std::string::npos);
  CHECK(without.find("final map (loops)") == std::string::npos);
  d.map_estimate = d.groundtruth;
  d.loops.push_back({12.5, Eigen::Vector3d(2.0, 0.0, 1.0), Eigen::Vector3d(1.9, 0.1, 1.0), 87, 0.0123, 0.21, false});
  d.loops.push_back({18.0, Eigen::Vector3d(-1.0, 1.0, 1.0), Eigen::Vector3d(-1.1, 1.0, 1.0), 40, 0.3, 2.5, true});
  const std::string html = render_report_html(d);
  for (const char* s : {"final map (loops)", "loops (2)", "<h2>Loops</h2>", "<td>12.50</td>", "<td>87</td>",
                        "<td>0.0123</td>", "<td>relocalization</td>", "<td>0.141</td>"}) {
    INFO(s);
    CHECK(html.find(s) != std::string::npos);
  }
  // One line per loop with a dot on its query end.
  std::size_t circles = 0;
  for (std::size_t at = html.find("<circle"); at != std::string::npos; at = html.find("<circle", at + 1)) ++circles;
  CHECK(circles == 2);
  CHECK(html.find("nan") == std::string::npos);
}

// The error budget section: the error plot with the mode phases shaded (one band per mode span, in
// the mode timeline's colours) and the worst window outlined, and the table of per-mode figures.
TEST_CASE("report.html shows the error budget plot and table when given one", "[eval][report][budget]") {
  ReportData d = example_report();
  CHECK(render_report_html(d).find("Error budget") == std::string::npos);  // absent: no section

  d.budget.present = true;
  d.budget.t_s = d.error_t_s;
  d.budget.error_m = d.error_m;
  d.budget.phases = {{"IMU_ONLY", 0, 0.0, std::nan(""), 0.0}, {"VO", 30, 1.5, 0.0321, 57.0}, {"VIO", 370, 17.0, 0.0123, 43.0}};
  d.budget.figures = {{"scale error (Sim(3))", "-0.668 %"}, {"yaw drift", "+0.569 deg/min"}};
  d.budget.has_worst = true;
  d.budget.worst_start_s = 11.25;
  d.budget.worst_end_s = 16.25;
  d.budget.worst_rmse_m = 0.0456;
  d.budget.worst_mode = "VIO";
  const std::string html = render_report_html(d);
  const std::size_t at = html.find("<h2>Error budget</h2>");
  REQUIRE(at != std::string::npos);
  const std::string section = html.substr(at, html.find("<h2>", at + 1) - at);
  CHECK(section.find("Error budget: position error by mode") != std::string::npos);
  // Three shaded mode bands (IMU_ONLY 0-1.5 s, VO 1.5-3 s, VIO 3-20 s) and the outlined worst window.
  std::size_t bands = 0;
  for (std::size_t p = section.find("fill-opacity='0.15'"); p != std::string::npos;
       p = section.find("fill-opacity='0.15'", p + 1)) {
    ++bands;
  }
  CHECK(bands == 3);
  CHECK(section.find("fill='#2ca02c' fill-opacity='0.15'") != std::string::npos);  // VIO's timeline colour
  CHECK(section.find("stroke-dasharray") != std::string::npos);
  CHECK(section.find("worst 5 s: 0.0456 m") != std::string::npos);
  // Table: one row per mode with its numbers, "-" where a mode has no pose, then the figures.
  CHECK(section.find("share of ATE&sup2; [%]") != std::string::npos);
  CHECK(section.find("<tr><td>VO</td><td>30</td><td>1.50</td><td>0.0321</td><td>57.0</td></tr>") != std::string::npos);
  CHECK(section.find("<tr><td>IMU_ONLY</td><td>0</td><td>0.00</td><td>-</td><td>0.0</td></tr>") != std::string::npos);
  CHECK(section.find("<td>yaw drift</td><td>+0.569 deg/min</td>") != std::string::npos);
  CHECK(html.find("nan") == std::string::npos);

  d.budget.phases.clear();
  CHECK(render_report_html(d).find("no per-mode split") != std::string::npos);
}

TEST_CASE("report.html renders non-blank in headless chromium", "[eval][report][chromium]") {
#if defined(__aarch64__) || defined(__arm__)
  WARN("SKIPPED: chromium screenshot test runs on the x86-64 host only (not under qemu)");
  return;
#else
  if (std::system("command -v chromium >/dev/null 2>&1") != 0) {
    WARN("SKIPPED: chromium not installed; add `chromium` to scripts/deps.sh (host_pkgs) to run this test");
    return;
  }
  const std::string dir = ums::test::make_temp_dir("eval_report_chromium");
  const std::string html = dir + "/report.html";
  std::string err;
  REQUIRE(write_report_html(example_report(), html, &err));
  const std::string shot = dir + "/shot.png";
  std::filesystem::create_directories(dir + "/profile");
  const std::string cmd = "timeout 120 chromium --headless --no-sandbox --disable-gpu --disable-background-networking "
                          "--disable-component-update --disable-sync --no-first-run --user-data-dir=" +
                          dir + "/profile --screenshot=" + shot + " --window-size=1200,900 file://" + html +
                          " >" + dir + "/chromium.log 2>&1";
  const int rc = std::system(cmd.c_str());
  INFO("chromium exit " << rc << ", log in " << dir << "/chromium.log");
  REQUIRE(std::filesystem::exists(shot));
  const double frac = non_white_fraction(shot);
  INFO("non-white fraction " << frac);
  // Plots, grid lines, text and the coloured mode bars cover a few percent of the page; a blank
  // or error page has almost none.
  CHECK(frac > 0.02);
  CHECK(frac < 0.9);
#endif
}
