#include "board/host/commands.hpp"

#include <exception>

#include "board/host/cli_args.hpp"
#include "core/common/version.hpp"

namespace ums::cli {
namespace {

constexpr const char* kUsage = R"(umsvins: stereo visual-inertial odometry (UMS-VINS) for embedded boards

usage: umsvins <command> [options]

  replay <dataset> [--config F] [--out DIR] [--start S] [--duration S] [--realtime]
                   [--frontend-only] [--quiet] [--deterministic] [--two-core] [--mavlink ...]
                   [--loop | --vocabulary F] [--load-map F] [--save-map F] [--map-spread-s S]
                   [--fault KIND:START_S:DURATION_S[:PARAM][,...]] [--fault-seed N]
      Run on an EuRoC-layout folder (the one holding mav0/). Writes DIR/stats.json
      (and DIR/trajectory.tum, DIR/report.html where those stages exist). Default DIR: out/replay.
      --loop: loop closure with the built-in vocabulary (--vocabulary F: with that one, from
      umsvins vocab train); the loop work runs on its own thread (not with --deterministic). Writes
      DIR/trajectory_map.tum (every frame in the final map, written at the end),
      DIR/trajectory_map_live.tum (in the map frame as flown) and DIR/loops.csv (docs/loop-closure.md);
      --save-map F writes the map at the end, --load-map F starts in a saved map's frame; with
      --mavlink the map frame goes out, each correction a reset or, with --map-spread-s S, a ramp.
      --no-tight-relocation: loops keep the verifier's measurement (no refinement in the window).
      --deterministic: solver rounds bounded by iterations, not wall time (same result anywhere).
      --two-core: the estimator on a second thread, overlapping the next frame's front end (the
      trajectory a single thread gives, to the byte with --deterministic; more frames per second
      where two cores are free; not with estimate_td).
      --fault: sensor faults on the way in (docs/robustness.md): imu-gap, imu-nan, imu-huge,
      imu-dup, imu-swap, frame-gap, frame-drop (PARAM probability), frame-freeze, frame-dup,
      right-lost, blackout, clock-jump (PARAM s), images-end; counted in stats.json "faults".
      MAVLink (replay and live): --mavlink udp:HOST:PORT|serial:PATH[:BAUD] sends ODOMETRY to a
      flight controller (docs/mavlink.md); --mavlink-rate HZ (default 30), --mavlink-imu-rate,
      --mavlink-vision (also VISION_POSITION/SPEED_ESTIMATE), --mavlink-sysid N (default 1).
      Every ODOMETRY is logged in DIR/mavlink_sent.csv. Use --realtime to feed a live receiver.
  simulate [--trajectory F] [--scenario NAME] [--seed N] [--start S] [--duration S]
           [--camera euroc|d455] [--max-frames N] [--exposure-change] [--blackout-s S]
           [--style procedural|photo] [--texture-dataset DIR] [--exposure-ms MS]
           [--td-ms MS] [--extrinsic-error-deg D] [--extrinsic-error-mm MM]
           [--imu-model ideal|realistic] [--imu-errors LIST] --out DIR
      Write a synthetic EuRoC-layout stereo+IMU dataset (scenarios: nominal, standstill-start,
      uniform-start, dark-start, textureless, impulses, right-dropout, blackout; car-turn and car-loop,
      the paper's car (Sec. IV-B): their own route and street world, no --trajectory). --style photo: a second,
      independent simulator (textures cut from the real images of the EuRoC dataset DIR, which it
      requires; larger room, uneven light, vignetting, motion blur over --exposure-ms, default 4;
      SE(3) trajectory, decimated IMU with real-sized biases). Default: procedural.
      --camera d455: 848x480 at 30 Hz, gyro 200 Hz, accelerometer 100 Hz interpolated onto the
      gyro's stamps (EuRoC: 752x480 at 20 Hz, IMU 200 Hz). Planted errors the written calibration
      does not know: --td-ms (images stamped td early: t_imu = t_cam + td), --extrinsic-error-deg
      and -mm (both cameras' T_b_c off by a rotation and a shift drawn from the seed).
      --imu-model realistic: the IMU also has rotor vibration, scale-factor and misalignment
      errors and a warm-up bias drift (docs/simulator.md); default ideal (the estimator's model).
      --imu-errors vibration,scale,misalignment,drift: only those (default all).
  eval --estimate F --groundtruth F [--align se3|sim3|posyaw] [--cam0-sensor-yaml F]
       [--stats DIR/stats.json] [--json F]
      Print ATE, RPE and the error budget (ATE per mode with --stats, scale, yaw and position
      drift, worst 5 s) of a trajectory against ground truth; --json: the same as JSON.
  sweep <dataset> --runs N --start-range A:B --out DIR [--seed S] [--duration D] [--config F]
      Repeat replay from random start times (robustness table).
  live [--config F] [--source d455|replay:DIR] [--out DIR] [--seconds S] [--mavlink ...]
       [--loop | --vocabulary F] [--load-map F] [--save-map F] [--map-spread-s S] [--two-core]
      Run the threaded board app on a RealSense D455 (or a recorded source). Ctrl-C stops it.
      --two-core: the estimator on its own thread, as for replay.
      Loop closure options as for replay (a keyframe the busy loop thread cannot take is dropped
      and counted: a frame never waits for loop closure).
  record --out DIR [--seconds S]             Record a D455 to the EuRoC layout.
  budget [--config F] [--dataset DIR]        Print the memory each pipeline component takes.
  vocab train <dataset>... --out F [--k K] [--levels L] [--every N] [--features M] [--seed S]
      Train the place-recognition vocabulary (BRIEF-256, hierarchical k-medians; default k 10,
      levels 4) on every N-th left image (default 10), M corners each (default 300).
  version                                    Print the version.

exit codes: 0 ok, 1 failure (the message names file, line or key), 2 capability not implemented
yet, 64 wrong usage.
)";

}  // namespace

int run_cli(const std::vector<std::string>& args, std::ostream& out, std::ostream& err) {
  if (args.empty() || args[0] == "help" || args[0] == "--help" || args[0] == "-h") {
    (args.empty() ? err : out) << kUsage;
    return args.empty() ? kExitUsage : kExitOk;
  }
  const std::string& command = args[0];
  const std::vector<std::string> rest(args.begin() + 1, args.end());
  try {
    if (command == "version" || command == "--version") {
      out << version_string() << "\n";
      return kExitOk;
    }
    if (command == "replay") return run_replay(rest, out, err);
    if (command == "simulate") return run_simulate(rest, out, err);
    if (command == "eval") return run_eval(rest, out, err);
    if (command == "sweep") return run_sweep(rest, out, err);
    if (command == "live") return run_live(rest, out, err);
    if (command == "record") return run_record(rest, out, err);
    if (command == "budget") return run_budget(rest, out, err);
    if (command == "vocab") return run_vocab(rest, out, err);
    err << "umsvins: unknown command '" << command << "'\n\n" << kUsage;
    return kExitUsage;
  } catch (const UsageError& e) {
    err << e.what() << "\n";
    return kExitUsage;
  } catch (const std::exception& e) {
    err << "umsvins " << command << ": " << e.what() << "\n";
    return kExitFailure;
  }
}

}  // namespace ums::cli
