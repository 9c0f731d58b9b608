#include "board/host/commands.hpp"

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include <Eigen/Core>
#include <catch2/catch.hpp>

#include "board/host/sweep.hpp"  // flatten_json
#include "profiling/alloc_counter.hpp"
#include "tests/common/test_paths.hpp"

namespace ums::cli {
namespace {

struct Run {
  int code = -1;
  std::string out;
  std::string err;
};

Run run(const std::vector<std::string>& args) {
  std::ostringstream out;
  std::ostringstream err;
  Run r;
  r.code = run_cli(args, out, err);
  r.out = out.str();
  r.err = err.str();
  return r;
}

std::string read_all(const std::string& path) {
  std::ifstream f(path);
  std::stringstream ss;
  ss << f.rdbuf();
  return ss.str();
}

// states.csv of a replay of the micro sequence's first seconds (at rest): one row per pose, and
// once in VIO the gyro bias estimate is the mean gyro reading at rest (the sequence's first 2 s).
void check_states_against_rest_gyro(const std::string& states_path, int expected_rows) {
  Eigen::Vector3d gyro_mean = Eigen::Vector3d::Zero();
  int n_imu = 0;
  std::ifstream imu(test::euroc_micro_dir() + "/mav0/imu0/data.csv");
  std::string line;
  long long t0 = -1;
  while (std::getline(imu, line)) {
    if (line.empty() || line[0] == '#') continue;
    std::replace(line.begin(), line.end(), ',', ' ');
    std::istringstream f(line);
    long long t = 0;
    Eigen::Vector3d w;
    f >> t >> w.x() >> w.y() >> w.z();
    if (t0 < 0) t0 = t;
    if (t - t0 > 2'000'000'000LL) break;
    gyro_mean += w;
    ++n_imu;
  }
  REQUIRE(n_imu > 300);
  gyro_mean /= n_imu;
  std::ifstream states(states_path);
  REQUIRE(states.good());
  std::getline(states, line);
  CHECK(line.find("bg_x") != std::string::npos);
  int rows = 0;
  std::string last_mode;
  Eigen::Vector3d bg = Eigen::Vector3d::Zero();
  while (std::getline(states, line)) {
    std::replace(line.begin(), line.end(), ',', ' ');
    std::istringstream f(line);
    double t_s = 0, v[3];
    int keyframe = 0;
    f >> t_s >> last_mode >> keyframe >> v[0] >> v[1] >> v[2] >> bg.x() >> bg.y() >> bg.z();
    CHECK(t_s > 1.4e9);
    ++rows;
  }
  CHECK(rows == expected_rows);
  CHECK(last_mode == "VIO");
  INFO("gyro bias estimate " << bg.transpose() << " rad/s, mean gyro at rest " << gyro_mean.transpose());
  // Measured 0.6 mrad/s apart (the real IMU's bias is (-0.002, 0.021, 0.078) rad/s).
  CHECK((bg - gyro_mean).norm() < 0.002);
}

}  // namespace

TEST_CASE("umsvins: usage errors exit 64 and name the mistake", "[cli]") {
  Run r = run({});
  CHECK(r.code == kExitUsage);
  CHECK(r.err.find("usage: umsvins") != std::string::npos);

  r = run({"frobnicate"});
  CHECK(r.code == kExitUsage);
  CHECK(r.err.find("unknown command 'frobnicate'") != std::string::npos);

  r = run({"replay"});
  CHECK(r.code == kExitUsage);
  CHECK(r.err.find("missing <dataset>") != std::string::npos);

  r = run({"replay", test::euroc_micro_dir(), "--bogus"});
  CHECK(r.code == kExitUsage);
  CHECK(r.err.find("unknown option '--bogus'") != std::string::npos);

  r = run({"replay", test::euroc_micro_dir(), "--duration", "ten"});
  CHECK(r.code == kExitUsage);
  CHECK(r.err.find("--duration needs a number, got 'ten'") != std::string::npos);

  r = run({"replay", test::euroc_micro_dir(), "--fault", "imu-gap:1:0.2,imu-hole:2:1"});
  CHECK(r.code == kExitUsage);
  CHECK(r.err.find("unknown kind 'imu-hole'") != std::string::npos);
}

TEST_CASE("a --config file's unknown keys reach the user as warnings (replay, budget)", "[cli][real]") {
  const std::string dir = test::make_temp_dir("cli_config");
  {
    std::ofstream f(dir + "/c.yaml");
    f << "%YAML:1.0\nmax_cnt: 120\nmax_cnt_typo: 3\n";
  }
  const std::string warning = "warning: " + dir + "/c.yaml: unknown key 'max_cnt_typo' ignored\n";
  const Run budget = run({"budget", "--dataset", test::euroc_micro_dir(), "--config", dir + "/c.yaml"});
  INFO(budget.err);
  REQUIRE(budget.code == kExitOk);
  CHECK(budget.err.find(warning) != std::string::npos);
  const Run replay = run({"replay", test::euroc_micro_dir(), "--out", dir + "/r", "--duration", "1.0", "--quiet",
                          "--deterministic", "--config", dir + "/c.yaml"});
  INFO(replay.err);
  REQUIRE(replay.code == kExitOk);
  CHECK(replay.err.find(warning) != std::string::npos);
  const Run plain = run({"replay", test::euroc_micro_dir(), "--out", dir + "/p", "--duration", "1.0", "--quiet", "--deterministic"});
  CHECK(plain.err.find("warning:") == std::string::npos);
}

TEST_CASE("umsvins replay --fault: the faults reach the pipeline and are counted in stats.json", "[cli][real][slow]") {
  const std::string dir = test::make_temp_dir("cli_fault");
  const Run r = run({"replay", test::euroc_micro_dir(), "--out", dir, "--duration", "3.0", "--quiet", "--deterministic",
                     "--fault", "imu-gap:1:0.3,frame-gap:2:0.5"});
  INFO(r.err);
  REQUIRE(r.code == kExitOk);
  const std::string stats = read_all(dir + "/stats.json");
  CHECK(stats.find("\"imu_lost\": 60") != std::string::npos);      // 0.3 s at 200 Hz
  CHECK(stats.find("\"frames_lost\": 10") != std::string::npos);   // 0.5 s at 20 Hz
  CHECK(stats.find("\"frames\": 51") != std::string::npos);        // 61 pairs in 3 s, 10 lost
  CHECK(stats.find("\"imu_gap_frames\": 0") == std::string::npos);  // the estimator saw the hole
}

TEST_CASE("umsvins budget measures every component it lists", "[cli]") {
  const Run r = run({"budget", "--dataset", test::euroc_micro_dir()});
  INFO(r.err);
  REQUIRE(r.code == kExitOk);
  CHECK(r.out.find("frontend") != std::string::npos);
  CHECK(r.out.find("estimator") != std::string::npos);
  // Two 752x480 frame buffers of the replay, exactly.
  CHECK(r.out.find("replay_images                721920 B") != std::string::npos);
  const std::size_t at = r.out.find("replay pipeline");
  REQUIRE(at != std::string::npos);
  const double pipeline_bytes = std::stod(r.out.substr(at + 15));
  // The pipeline's bytes are counted by the allocation hooks, which sanitizer builds leave out.
  if (!alloc_counter_available()) return;
  CHECK(pipeline_bytes > 1e6);   // pyramids of two 752x480 images alone are over 1 MB
  CHECK(pipeline_bytes < 64e6);  // and the whole pipeline fits a small board comfortably
}

TEST_CASE("umsvins record without a D455 fails cleanly and says why", "[cli]") {
  const std::string dir = test::make_temp_dir("cli_record");
  const Run r = run({"record", "--out", dir + "/rec", "--seconds", "1"});
  CHECK(r.code == kExitFailure);
  CHECK(r.err.find("umsvins record: ") != std::string::npos);
  CHECK_FALSE(std::filesystem::exists(dir + "/rec/mav0"));  // nothing half-written
}

TEST_CASE("umsvins live --source replay: the threaded path sees what the single-threaded replay sees",
          "[cli][real][slow]") {
  const std::string replay_dir = test::make_temp_dir("cli_live_replay");
  const std::string live_dir = test::make_temp_dir("cli_live_live");
  const Run replay = run({"replay", test::euroc_micro_dir(), "--out", replay_dir, "--duration", "2.0",
                          "--quiet"});
  REQUIRE(replay.code == kExitOk);
  const Run live = run({"live", "--source", "replay:" + test::euroc_micro_dir(), "--duration", "2.0",
                        "--out", live_dir});
  INFO(live.err);
  REQUIRE(live.code == kExitOk);
  CHECK(live.out.find("ring overflows: 0 frames, 0 IMU samples") != std::string::npos);

  // Same frames, same IMU, same front-end output: the features block must be identical.
  const auto block = [](const std::string& stats, const char* key) {
    const std::size_t a = stats.find(key);
    REQUIRE(a != std::string::npos);
    return stats.substr(a, stats.find('}', a) - a);
  };
  const std::string replay_stats = read_all(replay_dir + "/stats.json");
  const std::string live_stats = read_all(live_dir + "/stats.json");
  CHECK(block(live_stats, "\"features\"") == block(replay_stats, "\"features\""));
  CHECK(live_stats.find("\"frames\": 41") != std::string::npos);
  CHECK(replay_stats.find("\"frames\": 41") != std::string::npos);

  // The same poses, frame by frame (the estimator initializes at rest within this window).
  const auto poses = [](const std::string& path) {
    std::vector<std::vector<double>> rows;
    std::ifstream in(path);
    std::string line;
    while (std::getline(in, line)) {
      if (line.empty() || line[0] == '#') continue;
      std::istringstream f(line);
      std::vector<double> v(8);
      for (double& x : v) f >> x;
      rows.push_back(v);
    }
    return rows;
  };
  const auto a = poses(replay_dir + "/trajectory.tum");
  const auto b = poses(live_dir + "/trajectory.tum");
  REQUIRE(a.size() == 40);  // 41 frames; the first has no pose (velocity not yet known: no rest seen, no vision)
  REQUIRE(b.size() == a.size());
  double worst_m = 0.0;
  for (std::size_t i = 0; i < a.size(); ++i) {
    CHECK(a[i][0] == b[i][0]);
    for (int k = 1; k <= 3; ++k) worst_m = std::max(worst_m, std::abs(a[i][static_cast<std::size_t>(k)] - b[i][static_cast<std::size_t>(k)]));
  }
  CHECK(worst_m <= 1e-6);
  CHECK(poses(live_dir + "/trajectory_imu.tum").size() >= 300);  // 2 s at 200 Hz after the first frame
}

TEST_CASE("umsvins simulate writes a dataset that replay reads, eval scores an estimate of it",
          "[cli][sim]") {
  const std::string dir = test::make_temp_dir("cli_sim");
  const Run sim = run({"simulate", "--trajectory", test::groundtruth_dir() + "/MH01_GT.txt", "--duration",
                       "1.0", "--max-frames", "3", "--seed", "7", "--out", dir + "/ds", "--quiet"});
  INFO(sim.err);
  REQUIRE(sim.code == kExitOk);
  const std::string gt = dir + "/ds/mav0/state_groundtruth_estimate0/data.csv";
  REQUIRE(std::filesystem::exists(gt));

  const Run replay = run({"replay", dir + "/ds", "--out", dir + "/out", "--quiet"});
  INFO(replay.err);
  REQUIRE(replay.code == kExitOk);
  CHECK(replay.out.find("3 stereo pairs") != std::string::npos);

  // An estimate = every 10th ground-truth body pose with z alternately +-1 cm: no rigid
  // alignment can remove that, so ATE RMSE is 1 cm (to the alignment's small tilt).
  std::ifstream in(gt);
  std::ofstream tum(dir + "/est.tum");
  std::string line;
  int row = 0;
  while (std::getline(in, line)) {
    if (line.empty() || line[0] == '#') continue;
    if (row++ % 10 != 0) continue;
    std::stringstream ss(line);
    std::string cell;
    double v[8];
    for (double& x : v) {
      std::getline(ss, cell, ',');
      x = std::stod(cell);
    }
    const double dz = (row / 10) % 2 == 0 ? 0.01 : -0.01;
    char buf[256];
    std::snprintf(buf, sizeof(buf), "%.9f %.9f %.9f %.9f %.9f %.9f %.9f %.9f\n", v[0] * 1e-9, v[1], v[2],
                  v[3] + dz, v[5], v[6], v[7], v[4]);
    tum << buf;
  }
  tum.close();
  REQUIRE(row >= 200);  // 1 s at 200 Hz

  const Run eval = run({"eval", "--estimate", dir + "/est.tum", "--groundtruth", gt});
  INFO(eval.err);
  REQUIRE(eval.code == kExitOk);
  const std::size_t at = eval.out.find("ATE trans [m]: rmse ");
  REQUIRE(at != std::string::npos);
  const double rmse_m = std::stod(eval.out.substr(at + 20));
  CHECK(rmse_m == Approx(0.010).margin(0.001));

  // The error budget with the replay's mode timeline, as text and as JSON.
  const Run budget = run({"eval", "--estimate", dir + "/est.tum", "--groundtruth", gt, "--stats",
                          dir + "/out/stats.json", "--json", dir + "/eval.json"});
  INFO(budget.err);
  REQUIRE(budget.code == kExitOk);
  CHECK(budget.out.find("error budget (global SE(3) over") != std::string::npos);
  CHECK(budget.out.find("times in s since the first frame") != std::string::npos);
  const auto json = flatten_json(read_all(dir + "/eval.json"));
  CHECK(json.at("budget.has_phases") == "true");
  CHECK(std::stod(json.at("budget.ate_rmse_m")) == Approx(rmse_m).margin(1e-4));
  CHECK(std::stol(json.at("budget.phases.IMU_ONLY.poses")) + std::stol(json.at("budget.phases.VO.poses")) +
            std::stol(json.at("budget.phases.VIO.poses")) ==
        std::stol(json.at("matched_poses")));
  for (const char* key : {"budget.scale_error_pct", "budget.yaw_drift_deg_per_min", "budget.final_drift_pct",
                          "budget.worst_window.found", "ate.trans_m.rmse", "rpe.0.trans_m.rmse"}) {
    INFO(key);
    CHECK(json.count(key) == 1);
  }
  const Run no_stats = run({"eval", "--estimate", dir + "/est.tum", "--groundtruth", gt, "--stats", dir + "/none.json"});
  CHECK(no_stats.code == kExitUsage);
  CHECK(no_stats.err.find("none.json: cannot open") != std::string::npos);
  const Run bad_stats = run({"eval", "--estimate", dir + "/est.tum", "--groundtruth", gt, "--stats", dir + "/est.tum"});
  CHECK(bad_stats.code == kExitUsage);
  CHECK(bad_stats.err.find("--stats") != std::string::npos);

  CHECK(run({"eval", "--estimate", dir + "/est.tum", "--groundtruth", gt, "--align", "affine"}).code ==
        kExitUsage);
  CHECK(run({"simulate", "--scenario", "foggy", "--out", dir + "/x"}).code == kExitUsage);
  // The car scenarios drive their own route: a trajectory file is a usage slip, named.
  const Run car = run({"simulate", "--scenario", "car-turn", "--trajectory", gt, "--out", dir + "/x"});
  CHECK(car.code == kExitUsage);
  CHECK(car.err.find("--trajectory must be empty") != std::string::npos);
  CHECK(run({"eval", "--estimate", dir + "/missing.tum", "--groundtruth", gt}).code == kExitFailure);
}

// The photo style needs real images: without --texture-dataset it fails (exit 1) naming the flag,
// before writing anything; an unknown style is a usage error.
TEST_CASE("umsvins simulate --style photo without --texture-dataset fails naming the flag", "[cli][sim][slow]") {
  const std::string dir = test::make_temp_dir("cli_sim_photo");
  const Run r = run({"simulate", "--style", "photo", "--duration", "1", "--out", dir + "/ds", "--quiet"});
  CHECK(r.code == kExitFailure);
  CHECK(r.err.find("--texture-dataset") != std::string::npos);
  CHECK_FALSE(std::filesystem::exists(dir + "/ds"));
  CHECK(run({"simulate", "--style", "oil-painting", "--out", dir + "/x"}).code == kExitUsage);
  const Run ok = run({"simulate", "--style", "photo", "--texture-dataset", test::euroc_micro_dir(), "--trajectory",
                      test::groundtruth_dir() + "/V101_GT.txt", "--duration", "0.5", "--max-frames", "1",
                      "--exposure-ms", "3", "--out", dir + "/ok", "--quiet"});
  INFO(ok.err);
  CHECK(ok.code == kExitOk);
  CHECK(ok.out.find("photo style, 3 ms exposure") != std::string::npos);
}

TEST_CASE("umsvins replay: a missing dataset fails with its path", "[cli]") {
  const std::string missing = test::make_temp_dir("cli_missing") + "/no_such_dataset";
  const Run r = run({"replay", missing, "--out", test::make_temp_dir("cli_missing_out")});
  CHECK(r.code == kExitFailure);
  CHECK(r.err.find("no_such_dataset") != std::string::npos);
}

TEST_CASE("umsvins replay runs the front end on real EuRoC frames and writes stats.json",
          "[cli][real]") {
  // 2 s of the micro sequence (41 pairs at 20 Hz): the full 95 pairs are the reader's test, and
  // this one also runs under qemu.
  const std::string out_dir = test::make_temp_dir("cli_replay_micro");
  const Run r = run({"replay", test::euroc_micro_dir(), "--out", out_dir, "--duration", "2.0",
                     "--quiet"});
  INFO(r.err);
  REQUIRE(r.code == kExitOk);
  CHECK(r.out.find("41 stereo pairs") != std::string::npos);
  // One body pose per processed frame from the second on (the first frame comes before any
  // standstill or visual estimate: velocity unknown, no pose), in the dataset's clock.
  std::ifstream tum(out_dir + "/trajectory.tum");
  REQUIRE(tum.good());
  std::string line;
  int poses = 0;
  while (std::getline(tum, line)) {
    if (line.empty() || line[0] == '#') continue;
    std::istringstream fields(line);
    double v[8];
    int n = 0;
    while (n < 8 && fields >> v[n]) ++n;
    CHECK(n == 8);
    CHECK(v[0] > 1.4e9);  // seconds of the EuRoC clock, not from zero
    ++poses;
  }
  CHECK(poses == 40);
  check_states_against_rest_gyro(out_dir + "/states.csv", 40);
  const std::string report = read_all(out_dir + "/report.html");
  CHECK(report.find("Features per frame") != std::string::npos);
  // Self-contained: nothing fetched (the SVG namespace URI is a name, not a request).
  CHECK(report.find("src=\"http") == std::string::npos);
  CHECK(report.find("href=\"http") == std::string::npos);

  const std::string stats = read_all(out_dir + "/stats.json");
  CHECK(stats.find("\"frames_without_pose\": 1,") != std::string::npos);
  CHECK(stats.find("\"frames\": 41") != std::string::npos);
  CHECK(stats.find("\"duration_s\": 2,") != std::string::npos);
  CHECK(stats.find("\"saturated_samples\": 0") != std::string::npos);
  CHECK(stats.find("\"frontend\": {") != std::string::npos);
  // The textured room at rest: most features are stereo (3D), at least 100 per frame.
  const std::size_t at = stats.find("\"mean_3d\": ");
  REQUIRE(at != std::string::npos);
  const double mean_3d = std::stod(stats.substr(at + 11));
  CHECK(mean_3d >= 100.0);
}

namespace {

// V1_01's profile from its start, seed 3, rendered into out.
void render_v101(const std::string& out, const std::string& duration_s) {
  const Run sim = run({"simulate", "--trajectory", test::groundtruth_dir() + "/V101_GT.txt", "--duration", duration_s,
                       "--seed", "3", "--out", out, "--quiet"});
  INFO(sim.err);
  REQUIRE(sim.code == kExitOk);
}

}  // namespace

TEST_CASE("umsvins replay --deterministic: two replays write the same trajectory to the byte", "[cli][sim][slow]") {
  // The cross-architecture check (scripts/determinism.sh) compares host and aarch64 runs; this is
  // its precondition on one machine: no wall clock, no uninitialised memory, no run-to-run state.
  const std::string dir = test::make_temp_dir("cli_deterministic");
  render_v101(dir + "/ds", "2.5");
  const Run a = run({"replay", dir + "/ds", "--out", dir + "/a", "--quiet", "--deterministic"});
  const Run b = run({"replay", dir + "/ds", "--out", dir + "/b", "--quiet", "--deterministic"});
  INFO(a.err << b.err);
  REQUIRE(a.code == kExitOk);
  REQUIRE(b.code == kExitOk);
  const std::string ta = read_all(dir + "/a/trajectory.tum");
  const std::string tb = read_all(dir + "/b/trajectory.tum");
  CHECK(std::count(ta.begin(), ta.end(), '\n') >= 40);  // 20 Hz for 2.5 s: the estimator ran
  CHECK(ta == tb);
}

TEST_CASE("umsvins replay --two-core: the same trajectory and states to the byte as one core, 0 allocations",
          "[cli][sim][slow]") {
  const std::string dir = test::make_temp_dir("cli_two_core");
  render_v101(dir + "/ds", "4");
  const Run one = run({"replay", dir + "/ds", "--out", dir + "/one", "--quiet", "--deterministic"});
  const Run two = run({"replay", dir + "/ds", "--out", dir + "/two", "--quiet", "--deterministic", "--two-core"});
  INFO(one.err << two.err);
  REQUIRE(one.code == kExitOk);
  REQUIRE(two.code == kExitOk);
  const std::string t1 = read_all(dir + "/one/trajectory.tum");
  CHECK(std::count(t1.begin(), t1.end(), '\n') >= 70);  // 20 Hz for 4 s: the estimator ran
  CHECK(t1 == read_all(dir + "/two/trajectory.tum"));
  CHECK(read_all(dir + "/one/states.csv") == read_all(dir + "/two/states.csv"));
  const std::string stats = read_all(dir + "/two/stats.json");
  CHECK(stats.find("\"pipeline\": 2") != std::string::npos);
  CHECK(stats.find("\"backend_tasks\": ") != std::string::npos);
  // Steady state from the 50th frame: both threads' allocations are counted.
  CHECK(stats.find("\"heap_allocs_steady_state\": 0,") != std::string::npos);
  CHECK(read_all(dir + "/one/stats.json").find("\"pipeline\": 1") != std::string::npos);

  // An estimated camera-IMU offset stamps frame k+1 with frame k's estimate: no overlap possible.
  {
    std::ofstream cfg(dir + "/td.yaml");
    cfg << "%YAML:1.0\nestimate_td: 1\n";
  }
  const Run td = run({"replay", dir + "/ds", "--out", dir + "/td", "--quiet", "--two-core", "--config", dir + "/td.yaml"});
  CHECK(td.code != kExitOk);
  CHECK(td.err.find("estimate_td") != std::string::npos);
}

}  // namespace ums::cli
