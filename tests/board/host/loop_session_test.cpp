// Loop closure in umsvins replay (board/host/loop_session): --vocabulary turns it on, the
// map-frame trajectory sits beside the odometry, stats.json says what the closer did, and a bad
// vocabulary is refused with the file's name.
#include "board/host/loop_session.hpp"

#include <catch2/catch.hpp>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <map>
#include <sstream>

#include "board/host/commands.hpp"
#include "tests/common/test_paths.hpp"

namespace ums::cli {
namespace {

int run(const std::vector<std::string>& args, std::string* out, std::string* err) {
  std::ostringstream o, e;
  const int code = run_cli(args, o, e);
  *out = o.str();
  *err = e.str();
  return code;
}

std::string slurp(const std::string& path) {
  std::ifstream f(path);
  std::stringstream s;
  s << f.rdbuf();
  return s.str();
}

// TUM lines by stamp: t_s -> x y z qx qy qz qw.
std::map<std::string, std::vector<double>> read_tum(const std::string& path) {
  std::map<std::string, std::vector<double>> poses;
  std::ifstream f(path);
  std::string line;
  while (std::getline(f, line)) {
    if (line.empty() || line[0] == '#') continue;
    std::istringstream in(line);
    std::string t;
    std::vector<double> v(7);
    in >> t;
    for (double& x : v) in >> x;
    poses[t] = v;
  }
  return poses;
}

// The number after "key": inside stats.json's "loop" object (NaN when absent).
double loop_stat(const std::string& stats, const std::string& key) {
  const std::size_t loop = stats.find("\"loop\": {");
  if (loop == std::string::npos) return std::nan("");
  const std::size_t k = stats.find("\"" + key + "\": ", loop);
  if (k == std::string::npos) return std::nan("");
  const std::string v = stats.substr(k + key.size() + 4, 24);
  if (v.rfind("true", 0) == 0) return 1.0;
  if (v.rfind("false", 0) == 0) return 0.0;
  return std::strtod(v.c_str(), nullptr);
}

std::string micro_vocabulary(const std::string& dir) {
  const std::string path = dir + "/micro.voc";
  std::string out, err;
  REQUIRE(run({"vocab", "train", test::euroc_micro_dir(), "--out", path, "--k", "6", "--levels", "3", "--every", "10"},
              &out, &err) == kExitOk);
  return path;
}

}  // namespace

TEST_CASE("replay --vocabulary: both map trajectories equal the odometry until a loop moves them", "[cli][loop][slow]") {
  const std::string dir = test::make_temp_dir("loop_session");
  const std::string voc = micro_vocabulary(dir);
  std::string out, err;
  REQUIRE(run({"replay", test::euroc_micro_dir(), "--vocabulary", voc, "--out", dir + "/run", "--quiet", "--deterministic"},
              &out, &err) == kExitOk);
  INFO(out << err);
  const std::string stats = slurp(dir + "/run/stats.json");
  CHECK(loop_stat(stats, "enabled") == 1.0);
  // 4.75 s at rest: the frames that filled the window reach the database (at rest there are no
  // new keyframes); none is old enough (20 s) to be a candidate.
  CHECK(loop_stat(stats, "keyframes") >= 5);
  CHECK(loop_stat(stats, "candidates") == 0);
  CHECK(loop_stat(stats, "accepted") == 0);
  CHECK(loop_stat(stats, "peak_bytes") > 1e6);
  const auto odom = read_tum(dir + "/run/trajectory.tum");
  const auto live = read_tum(dir + "/run/trajectory_map_live.tum");
  const auto map = read_tum(dir + "/run/trajectory_map.tum");
  // As flown, map poses start once the first levelled keyframe left the window, then every frame
  // has one. The final map also places the frames of that odometry frame flown before it.
  REQUIRE(live.size() >= 40);
  CHECK(live.size() < odom.size());
  CHECK(map.size() >= live.size());
  CHECK(map.size() <= odom.size());
  CHECK(loop_stat(stats, "map_poses") == static_cast<double>(map.size()));
  CHECK(loop_stat(stats, "map_live_poses") == static_cast<double>(live.size()));
  for (const auto* poses : {&live, &map}) {
    for (const auto& [t, pose] : *poses) {
      REQUIRE(odom.count(t) == 1);
      for (int i = 0; i < 7; ++i) CHECK(std::abs(pose[i] - odom.at(t)[i]) < 1e-6);
    }
  }
  CHECK(slurp(dir + "/run/loops.csv").rfind("# t_query_s", 0) == 0);
}

// --loop needs no file: the built-in vocabulary. Without --deterministic the loop work runs on its
// own thread and a replay hands it every keyframe; with it, on the frame thread.
TEST_CASE("replay --loop: the built-in vocabulary, the loop work on its own thread", "[cli][loop][slow]") {
  const std::string dir = test::make_temp_dir("loop_builtin");
  std::string out, err;
  REQUIRE(run({"replay", test::euroc_micro_dir(), "--loop", "--out", dir + "/thread", "--quiet"}, &out, &err) == kExitOk);
  INFO(out << err);
  const std::string threaded = slurp(dir + "/thread/stats.json");
  CHECK(threaded.find("\"vocabulary\": \"builtin:sim_k10l4\"") != std::string::npos);
  CHECK(loop_stat(threaded, "vocabulary_checksum") == static_cast<double>(0x294545f3u));
  CHECK(loop_stat(threaded, "thread") == 1.0);
  CHECK(loop_stat(threaded, "keyframes_in") >= 5);
  CHECK(loop_stat(threaded, "thread_queued") == loop_stat(threaded, "keyframes_in"));
  CHECK(loop_stat(threaded, "thread_dropped") == 0);
  CHECK(read_tum(dir + "/thread/trajectory_map.tum").size() >= 40);
  REQUIRE(run({"replay", test::euroc_micro_dir(), "--loop", "--deterministic", "--out", dir + "/same", "--quiet"}, &out,
              &err) == kExitOk);
  const std::string same = slurp(dir + "/same/stats.json");
  CHECK(loop_stat(same, "thread") == 0.0);
  CHECK(loop_stat(same, "thread_queued") == 0);
  CHECK(loop_stat(same, "keyframes_in") >= 5);
}

TEST_CASE("replay without --vocabulary has no loop closure and says so", "[cli][loop]") {
  const std::string dir = test::make_temp_dir("loop_session_off");
  std::string out, err;
  REQUIRE(run({"replay", test::euroc_micro_dir(), "--out", dir, "--quiet", "--duration", "1"}, &out, &err) == kExitOk);
  CHECK(loop_stat(slurp(dir + "/stats.json"), "enabled") == 0.0);
  CHECK_FALSE(std::filesystem::exists(dir + "/trajectory_map.tum"));
}

TEST_CASE("replay --vocabulary refuses a missing or corrupt vocabulary, naming the file", "[cli][loop]") {
  const std::string dir = test::make_temp_dir("loop_session_bad");
  std::string out, err;
  CHECK(run({"replay", test::euroc_micro_dir(), "--vocabulary", dir + "/none.voc", "--out", dir, "--quiet"}, &out, &err) ==
        kExitFailure);
  CHECK(err.find(dir + "/none.voc") != std::string::npos);
  const std::string voc = micro_vocabulary(dir);
  std::string bytes = slurp(voc);
  bytes[bytes.size() / 2] = static_cast<char>(bytes[bytes.size() / 2] ^ 0x5a);
  std::ofstream(voc, std::ios::binary) << bytes;
  CHECK(run({"replay", test::euroc_micro_dir(), "--vocabulary", voc, "--out", dir, "--quiet"}, &out, &err) == kExitFailure);
  CHECK(err.find(voc) != std::string::npos);
  CHECK(err.find("not a usable vocabulary") != std::string::npos);
}

}  // namespace ums::cli

namespace ums::cli {

// The micro sequence saved as a map, then replayed again with it: the second run finds itself
// in the map at its first keyframe and its map poses are the first run's.
TEST_CASE("replay --save-map / --load-map: the same flight again is placed in the saved map", "[cli][loop]") {
  const std::string dir = test::make_temp_dir("loop_map");
  const std::string voc = micro_vocabulary(dir);
  const std::string map = dir + "/micro.map";
  std::string out, err;
  REQUIRE(run({"replay", test::euroc_micro_dir(), "--vocabulary", voc, "--save-map", map, "--out", dir + "/a", "--quiet",
               "--deterministic"}, &out, &err) == kExitOk);
  const std::string stats_a = slurp(dir + "/a/stats.json");
  CHECK(loop_stat(stats_a, "saved_map_bytes") > 1000);
  REQUIRE(run({"replay", test::euroc_micro_dir(), "--vocabulary", voc, "--load-map", map, "--out", dir + "/b", "--quiet",
               "--deterministic", "--mavlink", "udp:127.0.0.1:14999"}, &out, &err) == kExitOk);
  INFO(out << err);
  // The flight controller gets the map frame: its reset_counter steps at the re-levelling of the
  // odometry (0 -> 1), again when the relocalization places the run in the map (-> 2), and when the
  // window's tightly coupled relocation refines that loop a frame later (-> 3).
  std::ifstream sent(dir + "/b/mavlink_sent.csv");
  std::string line;
  std::getline(sent, line);
  std::vector<int> counters;
  while (std::getline(sent, line)) {
    std::stringstream fields(line);
    std::string f;
    for (int i = 0; i < 13; ++i) std::getline(fields, f, ',');
    if (counters.empty() || counters.back() != std::stoi(f)) counters.push_back(std::stoi(f));
  }
  CHECK(counters == std::vector<int>{0, 1, 2, 3});
  const std::string stats_b = slurp(dir + "/b/stats.json");
  CHECK(loop_stat(stats_b, "relocations_refined") == 1);
  CHECK(loop_stat(stats_b, "loaded_keyframes") == loop_stat(stats_a, "keyframes"));
  CHECK(loop_stat(stats_b, "relocalizations") == 1);
  const auto map_a = read_tum(dir + "/a/trajectory_map.tum");
  const auto map_b = read_tum(dir + "/b/trajectory_map.tum");
  REQUIRE(map_b.size() >= 40);
  int compared = 0;
  for (const auto& [t, pose] : map_b) {
    if (map_a.count(t) == 0) continue;
    const std::vector<double>& a = map_a.at(t);
    CHECK(std::hypot(pose[0] - a[0], pose[1] - a[1], pose[2] - a[2]) < 0.005);  // m: same images, same place
    ++compared;
  }
  CHECK(compared >= 40);
}

// Every malformed map is refused at start-up with the file's name and the reason.
TEST_CASE("replay --load-map refuses corrupt, truncated, foreign and misplaced map files", "[cli][loop]") {
  const std::string dir = test::make_temp_dir("loop_map_bad");
  const std::string voc = micro_vocabulary(dir);
  const std::string good = dir + "/good.map";
  std::string out, err;
  REQUIRE(run({"replay", test::euroc_micro_dir(), "--vocabulary", voc, "--save-map", good, "--out", dir + "/a", "--quiet",
               "--duration", "2"}, &out, &err) == kExitOk);
  const std::string bytes = slurp(good);
  REQUIRE(bytes.size() > 100);
  auto refused = [&](const std::string& name, const std::string& content, const std::string& reason,
                     const std::string& vocabulary) {
    const std::string path = dir + "/" + name;
    std::ofstream(path, std::ios::binary) << content;
    INFO(name);
    CHECK(run({"replay", test::euroc_micro_dir(), "--vocabulary", vocabulary, "--load-map", path, "--out", dir + "/b",
               "--quiet"}, &out, &err) == kExitFailure);
    CHECK(err.find(path + ": not a usable map: " + reason) != std::string::npos);
    INFO(err);
  };
  std::string flipped = bytes;
  flipped[bytes.size() / 2] = static_cast<char>(flipped[bytes.size() / 2] ^ 0x01);
  refused("flipped.map", flipped, "CRC mismatch", voc);
  refused("truncated.map", bytes.substr(0, bytes.size() - 9), "CRC mismatch", voc);
  refused("tiny.map", bytes.substr(0, 10), "truncated", voc);
  std::string magic = bytes;
  magic[0] = 'X';
  refused("magic.map", magic, "no UMSMAP01 magic", voc);
  REQUIRE(run({"vocab", "train", test::euroc_micro_dir(), "--out", dir + "/other.voc", "--k", "5", "--levels", "3",
               "--every", "10"}, &out, &err) == kExitOk);
  refused("foreign.map", bytes, "made with another vocabulary", dir + "/other.voc");
  CHECK(run({"replay", test::euroc_micro_dir(), "--load-map", good, "--out", dir + "/c", "--quiet"}, &out, &err) ==
        kExitUsage);
  CHECK(err.find("--vocabulary") != std::string::npos);
}

}  // namespace ums::cli

namespace ums::cli {

// The live app takes the same loop options: it finds itself in the saved map, as replay does.
TEST_CASE("live --vocabulary --load-map: the board app is placed in a saved map", "[cli][loop][slow]") {
  const std::string dir = test::make_temp_dir("loop_live");
  const std::string voc = micro_vocabulary(dir);
  const std::string map = dir + "/micro.map";
  std::string out, err;
  REQUIRE(run({"replay", test::euroc_micro_dir(), "--vocabulary", voc, "--save-map", map, "--out", dir + "/a", "--quiet"},
              &out, &err) == kExitOk);
  REQUIRE(run({"live", "--source", "replay:" + test::euroc_micro_dir(), "--vocabulary", voc, "--load-map", map, "--out",
               dir + "/live", "--quiet"}, &out, &err) == kExitOk);
  INFO(out << err);
  const std::string stats = slurp(dir + "/live/stats.json");
  CHECK(loop_stat(stats, "enabled") == 1.0);
  CHECK(loop_stat(stats, "relocalizations") == 1);
  CHECK(read_tum(dir + "/live/trajectory_map.tum").size() >= 40);
}

}  // namespace ums::cli
