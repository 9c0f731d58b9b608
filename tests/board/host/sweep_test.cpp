#include "board/host/sweep.hpp"

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

#include <catch2/catch.hpp>

#include "board/host/commands.hpp"
#include "profiling/eval/trajectory.hpp"
#include "profiling/json_writer.hpp"
#include "tests/common/test_paths.hpp"

namespace ums::cli {
namespace {

namespace fs = std::filesystem;

constexpr std::int64_t kT0Ns = 1403636580863555584LL;  // a real EuRoC stamp: full-size clock values
constexpr double kGtRateHz = 100.0;
constexpr double kGtLengthS = 80.0;

// A moving, turning flight (so an SE(3) alignment is well posed), body = IMU in the world.
eval::Trajectory make_groundtruth() {
  eval::Trajectory gt;
  gt.frame = eval::PoseFrame::kBody;
  const int n = static_cast<int>(kGtLengthS * kGtRateHz);
  for (int i = 0; i <= n; ++i) {
    const double t = i / kGtRateHz;
    eval::StampedPose p;
    p.t_ns = kT0Ns + static_cast<std::int64_t>(i) * 10'000'000LL;
    p.p_w_x = {2.0 * std::cos(0.3 * t), 1.5 * std::sin(0.4 * t), 1.0 + 0.3 * std::sin(0.7 * t)};
    p.q_w_x = Eigen::AngleAxisd(0.3 * t, Eigen::Vector3d::UnitZ()) *
              Eigen::AngleAxisd(0.1 * std::sin(t), Eigen::Vector3d::UnitX());
    gt.poses.push_back(p);
  }
  return gt;
}

// The EuRoC ground-truth csv (17 columns, q as w,x,y,z) of `gt` under <dataset>/mav0/.
void write_euroc_groundtruth(const std::string& dataset, const eval::Trajectory& gt) {
  const fs::path dir = fs::path(dataset) / "mav0" / "state_groundtruth_estimate0";
  fs::create_directories(dir);
  std::FILE* f = std::fopen((dir / "data.csv").string().c_str(), "w");
  REQUIRE(f != nullptr);
  std::fprintf(f, "#timestamp, p_RS_R_x [m], p_RS_R_y [m], p_RS_R_z [m], q_RS_w [], q_RS_x [], q_RS_y [], "
                  "q_RS_z [], v_RS_R_x [m s^-1], v_RS_R_y [m s^-1], v_RS_R_z [m s^-1], b_w_RS_S_x [rad s^-1], "
                  "b_w_RS_S_y [rad s^-1], b_w_RS_S_z [rad s^-1], b_a_RS_S_x [m s^-2], b_a_RS_S_y [m s^-2], "
                  "b_a_RS_S_z [m s^-2]\n");
  for (const eval::StampedPose& p : gt.poses) {
    std::fprintf(f, "%lld,%.9f,%.9f,%.9f,%.12f,%.12f,%.12f,%.12f,0,0,0,0,0,0,0,0,0\n",
                 static_cast<long long>(p.t_ns), p.p_w_x.x(), p.p_w_x.y(), p.p_w_x.z(), p.q_w_x.w(),
                 p.q_w_x.x(), p.q_w_x.y(), p.q_w_x.z());
  }
  std::fclose(f);
}

void write_stats(const std::string& run_dir, long frames, bool init_success) {
  JsonWriter w;
  w.begin_object();
  w.value("frames", static_cast<std::int64_t>(frames));
  w.begin_object("init").value("success", init_success).value("time_s", 0.85).value("case", 1).end_object();
  w.begin_array("modes");
  w.begin_object().value("t", 0.0).value("mode", "IMU_ONLY").end_object();
  w.end_array();
  w.end_object();
  std::ofstream(fs::path(run_dir) / "stats.json") << w.str();
}

// What a synthetic run writes: the ground truth from start_s for duration_s at 20 Hz (every 5th
// ground-truth pose), moved by a rigid transform the SE(3) alignment must remove, plus a planted
// error of +-error_m along one axis alternating pose by pose (zero mean, uncorrelated with the
// path), so the ATE RMSE after alignment is error_m to within 0.1 % (measured 2e-5).
struct Plant {
  double error_m = 0.0;
  double pose_share = 1.0;  // of the frames written as poses
  bool init_success = true;
  bool write_trajectory = true;
  int exit_code = 0;
};

long write_synthetic_run(const eval::Trajectory& gt, double start_s, double duration_s, const Plant& plant,
                         const std::string& run_dir) {
  const Eigen::Isometry3d T_est_gt = [] {
    Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
    T.linear() = (Eigen::AngleAxisd(0.7, Eigen::Vector3d::UnitZ()) *
                  Eigen::AngleAxisd(0.2, Eigen::Vector3d::UnitX()))
                     .toRotationMatrix();
    T.translation() = Eigen::Vector3d(5.0, -3.0, 2.0);
    return T;
  }();
  const std::size_t first = static_cast<std::size_t>(std::lround(start_s * kGtRateHz));
  const std::size_t count = static_cast<std::size_t>(std::lround(duration_s * 20.0));
  eval::Trajectory est;
  const Eigen::Vector3d axis = Eigen::Vector3d(1.0, 2.0, -0.5).normalized();
  const std::size_t written = static_cast<std::size_t>(std::floor(plant.pose_share * static_cast<double>(count)));
  for (std::size_t i = 0; i < written; ++i) {
    const eval::StampedPose& g = gt.poses.at(first + 5 * i);
    eval::StampedPose p;
    p.t_ns = g.t_ns;
    const double sign = (i % 2 == 0) ? 1.0 : -1.0;
    p.p_w_x = T_est_gt * (g.p_w_x + sign * plant.error_m * axis);
    p.q_w_x = Eigen::Quaterniond(T_est_gt.linear()) * g.q_w_x;
    est.poses.push_back(p);
  }
  if (plant.write_trajectory && !est.poses.empty()) eval::write_tum((fs::path(run_dir) / "trajectory.tum").string(), est);
  write_stats(run_dir, static_cast<long>(count), plant.init_success);
  return static_cast<long>(count);
}

std::string read_all(const fs::path& path) {
  std::ifstream f(path);
  std::stringstream ss;
  ss << f.rdbuf();
  return ss.str();
}

}  // namespace

TEST_CASE("sweep: start times are seeded, uniform in the range and the same on every platform", "[sweep]") {
  const std::vector<double> a = draw_start_times(30, 0.0, 60.0, 1);
  const std::vector<double> b = draw_start_times(30, 0.0, 60.0, 1);
  const std::vector<double> c = draw_start_times(30, 0.0, 60.0, 2);
  REQUIRE(a.size() == 30);
  CHECK(a == b);
  CHECK(a != c);
  double lo = 1e9, hi = -1e9, sum = 0.0;
  for (double s : a) {
    lo = std::min(lo, s);
    hi = std::max(hi, s);
    sum += s;
  }
  CHECK(lo >= 0.0);
  CHECK(hi <= 60.0);
  // 30 uniform draws on [0, 60] s: the mean is 30 s with a standard error of 3.2 s.
  CHECK(std::abs(sum / 30.0 - 30.0) < 10.0);
  // Spread over the range, not bunched: both ends of [0, 60] are reached within 10 s.
  CHECK(lo < 10.0);
  CHECK(hi > 50.0);
  // Pinned on the host; the aarch64 build must draw the same table.
  CHECK(a[0] == Approx(draw_start_times(1, 0.0, 1.0, 1)[0] * 60.0).epsilon(1e-15));
  char first[32];
  std::snprintf(first, sizeof first, "%.9f", a[0]);
  CHECK(std::string(first) == "8.032598641");
  // A degenerate range gives that start every time.
  for (double s : draw_start_times(5, 12.5, 12.5, 7)) CHECK(s == 12.5);
}

TEST_CASE("sweep: stats.json is read by dotted keys", "[sweep]") {
  const auto m = flatten_json(
      R"({"frames": 95, "init": {"success": true, "time_s": 1.5e-1, "case": "imu \"only\""},
          "modes": [{"t": 0, "mode": "VO"}, {"t": 2.5, "mode": "VIO"}], "empty": {}, "list": [],
          "x": null, "neg": -3})");
  CHECK(m.at("frames") == "95");
  CHECK(m.at("init.success") == "true");
  CHECK(m.at("init.time_s") == "1.5e-1");
  CHECK(m.at("init.case") == "imu \"only\"");
  CHECK(m.at("modes.1.mode") == "VIO");
  CHECK(m.at("modes.1.t") == "2.5");
  CHECK(m.at("x") == "null");
  CHECK(m.at("neg") == "-3");
  CHECK(m.count("empty") == 0);
  CHECK_THROWS_WITH(flatten_json(R"({"a": 1,})"), Catch::Contains("byte"));
  CHECK_THROWS(flatten_json(R"({"a": tru})"));
  CHECK_THROWS(flatten_json(R"({"a": 1} x)"));
  CHECK_THROWS(flatten_json(R"({"a": "open)"));
}

TEST_CASE("sweep: summary is mean and sample standard deviation over successful runs only", "[sweep]") {
  std::vector<SweepRun> runs(6);
  const double rmse[6] = {0.04, 0.05, 0.06, 9.0, 0.07, -1.0};
  for (int i = 0; i < 6; ++i) {
    runs[static_cast<std::size_t>(i)].rmse_m = rmse[i];
    runs[static_cast<std::size_t>(i)].success = !(i == 3 || i == 5);
  }
  const SweepSummary s = summarize(runs);
  CHECK(s.runs == 6);
  CHECK(s.failures == 2);
  CHECK(s.rmse_mean_m == Approx(0.055).epsilon(1e-12));
  // {0.04, 0.05, 0.06, 0.07}: sum of squared deviations 0.0005, / (4 - 1).
  CHECK(s.rmse_std_m == Approx(std::sqrt(0.0005 / 3.0)).epsilon(1e-12));

  runs.resize(1);
  CHECK(summarize(runs).rmse_std_m == 0.0);
  runs[0].success = false;
  CHECK(summarize(runs).rmse_mean_m < 0.0);
}

TEST_CASE("sweep: planted errors come back as RMSE, failures are counted with their reason", "[sweep]") {
  const std::string dir = test::make_temp_dir("sweep_loop");
  const std::string dataset = dir + "/dataset";
  const eval::Trajectory gt = make_groundtruth();
  write_euroc_groundtruth(dataset, gt);
  const eval::Trajectory gt_read = eval::read_euroc_csv(sweep_groundtruth_path(dataset));
  REQUIRE(gt_read.poses.size() == gt.poses.size());

  SweepOptions options;
  options.dataset = dataset;
  options.out_dir = dir + "/sweep";
  options.runs = 8;
  options.start_min_s = 5.0;
  options.start_max_s = 60.0;
  options.seed = 3;
  // Runs 1-4 succeed with 1, 2, 3, 4 cm of planted error; 5-8 fail one way each.
  const Plant plants[8] = {
      {0.01, 1.0, true, true, 0},  {0.02, 1.0, true, true, 0},  {0.03, 1.0, true, true, 0},
      {0.04, 0.95, true, true, 0},  // 95% of the frames with a pose: still a success
      {0.01, 1.0, true, false, 0},  // no trajectory.tum (today's replay without an estimator)
      {0.01, 1.0, false, true, 0},  // initialization failed
      {0.01, 0.5, true, true, 0},   // poses for half the frames
      {0.01, 1.0, true, true, 1},   // replay exited with an error
  };
  std::vector<double> seen_starts;
  int call = 0;
  const SweepRunner runner = [&](double start_s, const std::string& run_dir) {
    seen_starts.push_back(start_s);
    CHECK(fs::is_directory(run_dir));
    CHECK(fs::is_empty(run_dir));
    const Plant& plant = plants[call++];
    write_synthetic_run(gt_read, start_s, 10.0, plant, run_dir);
    RunOutcome o;
    o.exit_code = plant.exit_code;
    if (o.exit_code != 0) o.message = "mav0/cam0/data.csv:3: bad row";
    return o;
  };
  std::ostringstream progress;
  const SweepResult result = run_sweep_loop(options, gt_read, runner, progress);

  REQUIRE(result.runs.size() == 8);
  CHECK(seen_starts == draw_start_times(8, 5.0, 60.0, 3));
  for (int k = 0; k < 8; ++k) {
    const SweepRun& r = result.runs[static_cast<std::size_t>(k)];
    INFO("run " << r.run << ": " << r.reason);
    CHECK(r.run == k + 1);
    CHECK(r.start_s == seen_starts[static_cast<std::size_t>(k)]);
    CHECK(r.frames == 200);
    CHECK(r.success == (k < 4));
  }
  // The SE(3) alignment removes the 0.7 rad / 5.4 m offset; what is left is the planted error.
  for (int k = 0; k < 4; ++k) {
    CHECK(result.runs[static_cast<std::size_t>(k)].rmse_m == Approx(0.01 * (k + 1)).epsilon(1e-3));
  }
  CHECK(result.runs[3].poses == 190);
  CHECK(result.runs[4].reason == "no trajectory.tum");
  CHECK(result.runs[4].rmse_m < 0.0);
  CHECK(result.runs[5].reason == "initialization failed");
  CHECK(result.runs[5].rmse_m == Approx(0.01).epsilon(1e-3));  // measured, but not counted
  CHECK(result.runs[6].reason == "poses for 100 of 200 frames (50.0%, need 90%)");
  CHECK(result.runs[7].reason == "replay exited with code 1 (mav0/cam0/data.csv:3: bad row)");

  const SweepSummary& s = result.summary;
  CHECK(s.runs == 8);
  CHECK(s.failures == 4);
  CHECK(s.rmse_mean_m == Approx(0.025).epsilon(1e-3));
  CHECK(s.rmse_std_m == Approx(std::sqrt(0.0005 / 3.0)).epsilon(1e-3));  // 0.0129 m
  CHECK(progress.str().find("sweep: run 5/8") != std::string::npos);
  CHECK(progress.str().find("FAILED: no trajectory.tum") != std::string::npos);

  // sweep.json carries the same numbers.
  const auto json = flatten_json(sweep_json(options, result));
  CHECK(json.at("dataset") == dataset);
  CHECK(json.at("runs.0.run") == "1");
  CHECK(std::stod(json.at("runs.1.rmse_m")) == Approx(result.runs[1].rmse_m).epsilon(1e-15));
  CHECK(std::stod(json.at("runs.2.start_s")) == Approx(result.runs[2].start_s).epsilon(1e-8));
  CHECK(json.at("runs.0.success") == "true");
  CHECK(json.at("runs.0.reason") == "null");
  CHECK(json.at("runs.4.success") == "false");
  CHECK(json.at("runs.4.rmse_m") == "null");
  CHECK(json.at("runs.6.reason") == result.runs[6].reason);
  CHECK(json.at("summary.runs") == "8");
  CHECK(json.at("summary.failures") == "4");
  CHECK(std::stod(json.at("summary.rmse_mean")) == Approx(s.rmse_mean_m).epsilon(1e-15));
  CHECK(std::stod(json.at("summary.rmse_std")) == Approx(s.rmse_std_m).epsilon(1e-15));

  std::ostringstream table;
  print_sweep_table(result, table);
  CHECK(table.str().find("FAILED: initialization failed") != std::string::npos);
  CHECK(table.str().find("8 runs, 4 failed") != std::string::npos);
}

TEST_CASE("sweep: a rerun into the same folder does not score the previous run's files", "[sweep]") {
  const std::string dir = test::make_temp_dir("sweep_rerun");
  const eval::Trajectory gt = make_groundtruth();
  SweepOptions options;
  options.dataset = dir;
  options.out_dir = dir + "/sweep";
  options.runs = 1;
  options.start_min_s = 1.0;
  options.start_max_s = 1.0;
  std::ostringstream progress;
  const SweepResult first = run_sweep_loop(options, gt, [&](double start_s, const std::string& run_dir) {
    write_synthetic_run(gt, start_s, 5.0, Plant{0.02, 1.0, true, true, 0}, run_dir);
    return RunOutcome{};
  }, progress);
  CHECK(first.runs[0].success);
  CHECK(first.runs[0].rmse_m == Approx(0.02).epsilon(1e-3));
  const SweepResult second =
      run_sweep_loop(options, gt, [](double, const std::string&) { return RunOutcome{}; }, progress);
  CHECK_FALSE(second.runs[0].success);
  CHECK(second.runs[0].reason == "no stats.json; no trajectory.tum");
  CHECK(second.summary.failures == 1);
  CHECK(second.summary.rmse_mean_m < 0.0);
}

TEST_CASE("sweep: a trajectory stamped on another clock than the ground truth is a failure", "[sweep]") {
  // The replay contract: TUM stamps in seconds of the dataset clock. Stamps from 0 match nothing.
  const std::string dir = test::make_temp_dir("sweep_clock");
  const eval::Trajectory gt = make_groundtruth();
  eval::Trajectory est;
  for (std::size_t i = 0; i < 100; ++i) {
    eval::StampedPose p = gt.poses[5 * i];
    p.t_ns -= kT0Ns;
    est.poses.push_back(p);
  }
  eval::write_tum(dir + "/trajectory.tum", est);
  write_stats(dir, 100, true);
  const SweepRun r = score_run(1, 0.0, RunOutcome{}, dir, gt, 0.9);
  CHECK_FALSE(r.success);
  CHECK(r.poses == 100);
  CHECK(r.rmse_m < 0.0);
  CHECK(r.reason.find("ATE not computed") != std::string::npos);
}

TEST_CASE("umsvins sweep: usage errors exit 64 and name the mistake", "[sweep]") {
  const std::string dir = test::make_temp_dir("sweep_usage");
  const std::string dataset = dir + "/dataset";
  fs::create_directories(dataset + "/mav0");
  struct Case {
    std::vector<std::string> args;
    const char* message;
  };
  const Case cases[] = {
      {{"sweep", "--runs", "3", "--start-range", "0:10", "--out", dir + "/o"}, "missing <dataset>"},
      {{"sweep", dataset, "--runs", "3", "--start-range", "10:5", "--out", dir + "/o"}, "A <= B"},
      {{"sweep", dataset, "--runs", "3", "--start-range", "0-10", "--out", dir + "/o"}, "needs A:B"},
      {{"sweep", dataset, "--runs", "3", "--start-range", "-5:10", "--out", dir + "/o"}, "0 <= A <= B"},
      {{"sweep", dataset, "--runs", "0", "--start-range", "0:10", "--out", dir + "/o"}, "--runs must be"},
      {{"sweep", dataset, "--runs", "x", "--start-range", "0:10", "--out", dir + "/o"}, "whole number"},
      {{"sweep", dataset, "--start-range", "0:10", "--out", dir + "/o"}, "--runs is required"},
      {{"sweep", dataset, "--runs", "3", "--out", dir + "/o"}, "--start-range A:B is required"},
      {{"sweep", dataset, "--runs", "3", "--start-range", "0:10"}, "--out is required"},
      {{"sweep", dataset, "--runs", "3", "--start-range", "0:10", "--out", dir + "/o", "--seed", "-1"},
       "--seed must be >= 0"},
      {{"sweep", dir + "/nowhere", "--runs", "3", "--start-range", "0:10", "--out", dir + "/o"},
       "is not a dataset"},
  };
  for (const Case& c : cases) {
    std::ostringstream out, err;
    const int code = run_cli(c.args, out, err);
    INFO(c.message << " -> " << err.str());
    CHECK(code == kExitUsage);
    CHECK(err.str().find(c.message) != std::string::npos);
  }
  CHECK_FALSE(fs::exists(dir + "/o"));

  // A dataset without ground truth cannot be scored: failure (1), named, nothing run.
  std::ostringstream out, err;
  CHECK(run_cli({"sweep", dataset, "--runs", "2", "--start-range", "0:1", "--out", dir + "/o"}, out, err) ==
        kExitFailure);
  CHECK(err.str().find("state_groundtruth_estimate0/data.csv: no ground truth") != std::string::npos);
  CHECK_FALSE(fs::exists(dir + "/o"));
}

TEST_CASE("umsvins sweep: replays in-process, a replay that cannot run is a listed failure", "[sweep]") {
  // A dataset with ground truth but no sensor data: replay throws on open, each run fails with
  // the replay's own message, and the sweep still writes its table and sweep.json.
  const std::string dir = test::make_temp_dir("sweep_cli_fail");
  const std::string dataset = dir + "/dataset";
  write_euroc_groundtruth(dataset, make_groundtruth());
  std::ostringstream out, err;
  const int code = run_cli({"sweep", dataset, "--runs", "2", "--start-range", "0:30", "--out", dir + "/o",
                            "--duration", "5"},
                           out, err);
  INFO(out.str() << err.str());
  CHECK(code == kExitFailure);  // no run succeeded: no statistic
  const auto json = flatten_json(read_all(fs::path(dir) / "o" / "sweep.json"));
  CHECK(json.at("summary.runs") == "2");
  CHECK(json.at("summary.failures") == "2");
  CHECK(json.at("summary.rmse_mean") == "null");
  CHECK(json.at("runs.1.reason").find("replay exited with code 1") != std::string::npos);
  CHECK(json.at("runs.1.reason").find("no trajectory.tum") != std::string::npos);
  CHECK(fs::exists(fs::path(dir) / "o" / "run_2" / "replay.log"));
  CHECK(out.str().find("2 runs, 2 failed") != std::string::npos);
  CHECK(err.str().find("sweep: run 2/2") != std::string::npos);
}

TEST_CASE("umsvins sweep: a real replay of the micro sequence is run and scored", "[sweep]") {
  // The real micro sequence (symlinked, read-only) with the ground truth the vehicle has: it
  // stands still for all 4.75 s (< 5 mm), so a static pose at 200 Hz is its ground truth.
  const std::string dir = test::make_temp_dir("sweep_micro");
  const std::string dataset = dir + "/dataset";
  const fs::path micro = fs::path(test::euroc_micro_dir()) / "mav0";
  fs::create_directories(fs::path(dataset) / "mav0");
  for (const char* entry : {"cam0", "cam1", "imu0", "body.yaml"}) {
    fs::create_symlink(micro / entry, fs::path(dataset) / "mav0" / entry);
  }
  eval::Trajectory still;
  std::int64_t t0_ns = 0;
  {
    std::ifstream cam0(micro / "cam0" / "data.csv");
    std::string line;
    std::getline(cam0, line);  // header
    std::getline(cam0, line);
    t0_ns = std::stoll(line.substr(0, line.find(',')));
  }
  for (int i = -200; i < 6 * 200; ++i) {
    eval::StampedPose p;
    p.t_ns = t0_ns + static_cast<std::int64_t>(i) * 5'000'000LL;
    p.p_w_x = {0.8, 2.2, 0.1};
    still.poses.push_back(p);
  }
  write_euroc_groundtruth(dataset, still);

  std::ostringstream out, err;
  const int code = run_cli({"sweep", dataset, "--runs", "1", "--start-range", "0.5:1.5", "--duration", "1",
                            "--out", dir + "/o"},
                           out, err);
  INFO(out.str() << err.str());
  REQUIRE((code == kExitOk || code == kExitFailure));
  const auto json = flatten_json(read_all(fs::path(dir) / "o" / "sweep.json"));
  // 1 s of 20 Hz stereo from the start drawn in [0.5, 1.5] s.
  const double start_s = std::stod(json.at("runs.0.start_s"));
  CHECK(start_s >= 0.5);
  CHECK(start_s <= 1.5);
  CHECK(std::stol(json.at("runs.0.frames")) >= 19);
  CHECK(std::stol(json.at("runs.0.frames")) <= 21);
  CHECK(fs::exists(fs::path(dir) / "o" / "run_1" / "stats.json"));
  if (json.at("runs.0.success") == "true") {
    CHECK(code == kExitOk);
    CHECK(std::stod(json.at("runs.0.rmse_m")) < 0.05);  // a vehicle standing still
  } else {
    CHECK(code == kExitFailure);
    CHECK_FALSE(json.at("runs.0.reason").empty());
  }
}

}  // namespace ums::cli
