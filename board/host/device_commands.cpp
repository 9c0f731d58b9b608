// umsvins record and umsvins live: the D455 (or, for live, a recorded source) into the pipeline.
//
// live runs the threads of the board app: a capture thread pushes into a lock-free bridge, the
// pipeline thread drains it. SIGINT stops both cleanly and the stats are still written.

#include <atomic>
#include <chrono>
#include <csignal>
#include <filesystem>
#include <fstream>
#include <thread>

#include "board/config/app_config.hpp"
#include "board/host/cli_args.hpp"
#include "board/host/commands.hpp"
#include "board/host/replay_pipeline.hpp"
#include "core/common/version.hpp"
#include "hal/d455/d455_device.hpp"
#include "hal/d455/nominal_calibration.hpp"
#include "board/host/loop_session.hpp"
#include "board/host/mavlink_args.hpp"
#include "hal/d455/realtime.hpp"
#include "hal/d455/record_euroc.hpp"
#include "hal/d455/recorder.hpp"
#include "hal/d455/sys.hpp"
#include "hal/d455/thread_bridge.hpp"
#include "hal/replay/euroc_reader.hpp"
#include "profiling/alloc_counter.hpp"
#include "profiling/json_writer.hpp"

namespace ums::cli {
namespace {

std::atomic<bool> g_stop{false};  // set by SIGINT/SIGTERM only: the one global a signal handler needs

extern "C" void on_sigint(int) { g_stop.store(true); }

class SigintScope {
 public:
  SigintScope() {
    g_stop.store(false);
    // Ctrl-C and a service manager's stop end a run the same way: the recorder closes its files.
    previous_ = std::signal(SIGINT, on_sigint);
    previous_term_ = std::signal(SIGTERM, on_sigint);
  }
  ~SigintScope() {
    std::signal(SIGINT, previous_);
    std::signal(SIGTERM, previous_term_);
  }

 private:
  void (*previous_)(int) = SIG_DFL;
  void (*previous_term_)(int) = SIG_DFL;
};

d455::D455Options device_options_from(const AppConfig& config) {
  d455::D455Options o;
  o.camera.width = config.rig.cam[0].width;
  o.camera.height = config.rig.cam[0].height;
  o.camera.fps = static_cast<int>(config.rig.cam[0].rate_hz + 0.5);
  o.validate();
  return o;
}

AppConfig device_config(const Args& args, std::ostream& err) {
  const RigCalibration nominal = d455::d455_nominal_calibration(848, 480, 30.0, 400.0);
  return config_of(args, nominal, err);
}

// A replay source may wait for the consumer (a sensor cannot): each frame goes in only once the
// pipeline has taken everything before it, so the threaded run sees exactly what a
// single-threaded replay sees, and the bridge never overflows for want of speed.
class BackpressureSink final : public MeasurementSink {
 public:
  explicit BackpressureSink(d455::ThreadBridge* bridge) : bridge_(bridge) {}
  void on_imu(const ImuSample& s) override { bridge_->on_imu(s); }
  void on_stereo(const StereoFrame& f) override {
    while (bridge_->pending() > 0 && !g_stop.load()) std::this_thread::sleep_for(std::chrono::microseconds(200));
    bridge_->on_stereo(f);
  }

 private:
  d455::ThreadBridge* bridge_;
};

void write_text(const std::filesystem::path& path, const std::string& text) {
  std::ofstream f(path);
  f << text;
  if (!f) throw std::runtime_error(path.string() + ": cannot write");
}

}  // namespace

int run_record(const std::vector<std::string>& argv, std::ostream& out, std::ostream& err) {
  const Args args("record", argv, {}, {"out", "seconds", "config"});
  args.require_positionals(0, "");
  const std::string out_dir = args.require("out");
  d455::RecordOptions record_options;
  record_options.seconds = args.get_double("seconds", 0.0);
  record_options.validate();
  const AppConfig config = device_config(args, err);

  d455::LinuxSys sys;
  const d455::SysFs fs;
  d455::D455Device device(sys, fs, device_options_from(config));
  std::string error;
  if (device.open(&error) != Status::kOk) {
    err << "umsvins record: " << error << "\n";
    return kExitFailure;
  }
  SigintScope sigint;
  d455::RecordSummary summary;
  const Status st = d455::record_euroc(device, config.rig, out_dir, record_options, &g_stop, &summary, &error);
  out << "record: " << summary.frames << " stereo pairs, " << summary.imu_samples << " IMU samples in "
      << summary.duration_s << " s, " << summary.restarts << " stream restarts -> " << out_dir << "\n";
  if (st != Status::kOk) {
    err << "umsvins record: " << error << " (what was recorded is kept)\n";
    return kExitFailure;
  }
  return kExitOk;
}

namespace {

// Where live data comes from: a recorded dataset pushed as if live, or the D455.
struct LiveSource {
  std::unique_ptr<hal::EurocReader> reader;
  std::unique_ptr<d455::LinuxSys> sys;
  std::unique_ptr<d455::D455Device> device;
  AppConfig config;
};

// nullptr after printing why when the D455 cannot be opened or started.
std::unique_ptr<LiveSource> open_source(const Args& args, const std::string& source, std::ostream& err) {
  auto s = std::make_unique<LiveSource>();
  if (source.rfind("replay:", 0) == 0) {
    hal::EurocReaderOptions reader_options;
    reader_options.duration_s = args.get_double("duration", 0.0);
    s->reader = std::make_unique<hal::EurocReader>();
    s->reader->open(source.substr(7), reader_options);
    s->config = config_of(args, s->reader->calibration(), err);
  } else if (source == "d455") {
    s->config = device_config(args, err);
    s->sys = std::make_unique<d455::LinuxSys>();
    s->device = std::make_unique<d455::D455Device>(*s->sys, d455::SysFs(), device_options_from(s->config));
    std::string error;
    if (s->device->open(&error) != Status::kOk || s->device->start(&error) != Status::kOk) {
      err << "umsvins live: " << error << "\n";
      return nullptr;
    }
  } else {
    throw UsageError("umsvins live: --source must be d455 or replay:DIR, got '" + source + "'");
  }
  return s;
}

// Poses: camera-rate optimized (trajectory.tum) and IMU-rate propagated (trajectory_imu.tum).
struct LivePoseFiles {
  std::filesystem::path trajectory_path, imu_path;
  std::FILE* trajectory = nullptr;
  std::FILE* imu_poses = nullptr;
};

LivePoseFiles open_pose_files(const std::filesystem::path& out_dir, ReplayPipeline& pipeline) {
  LivePoseFiles f{out_dir / "trajectory.tum", out_dir / "trajectory_imu.tum"};
  f.trajectory = std::fopen(f.trajectory_path.c_str(), "w");
  f.imu_poses = std::fopen(f.imu_path.c_str(), "w");
  if (f.trajectory == nullptr || f.imu_poses == nullptr) {
    if (f.trajectory != nullptr) std::fclose(f.trajectory);
    if (f.imu_poses != nullptr) std::fclose(f.imu_poses);
    throw std::runtime_error(out_dir.string() + ": cannot open the pose files for writing");
  }
  pipeline.set_trajectory_output(f.trajectory);
  pipeline.set_imu_pose_output(f.imu_poses);
  return f;
}

// false when a write failed (disk full?).
bool close_pose_files(LivePoseFiles* f, ReplayPipeline& pipeline) {
  pipeline.set_trajectory_output(nullptr);
  pipeline.set_imu_pose_output(nullptr);
  const bool trajectory_ok = std::fclose(f->trajectory) == 0;
  const bool imu_ok = std::fclose(f->imu_poses) == 0;
  return trajectory_ok && imu_ok;
}

struct ProducerResult {
  Status status = Status::kOk;
  std::string error;
};

// The capture thread fills the bridge (the dataset with backpressure, or the D455 until Ctrl-C,
// --seconds or a stall); this thread drains it into the pipeline until both are done.
ProducerResult run_threads(LiveSource& src, d455::ThreadBridge& bridge, ReplayPipeline& pipeline, double seconds) {
  SigintScope sigint;
  std::atomic<bool> producer_done{false};
  ProducerResult result;
  const auto start = std::chrono::steady_clock::now();
  std::thread capture([&] {
    if (src.reader) {
      BackpressureSink sink(&bridge);
      result.status = src.reader->push_all(sink);
      if (result.status != Status::kOk) result.error = src.reader->error();
    } else {
      d455::set_realtime_priority(10);  // best effort: refused without CAP_SYS_NICE
      while (!g_stop.load()) {
        if (seconds > 0.0 && std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count() >= seconds) {
          break;
        }
        if (src.device->poll_once(bridge, 200) == Status::kIoError) {
          result.status = Status::kIoError;
          result.error = "the D455 stopped delivering (unplugged?)";
          break;
        }
      }
      src.device->stop();
    }
    producer_done.store(true);
  });
  for (;;) {
    const bool done = producer_done.load();
    if (bridge.drain(pipeline) == 0) {
      if (done && bridge.pending() == 0) break;
      std::this_thread::sleep_for(std::chrono::microseconds(500));
    }
  }
  capture.join();
  return result;
}

ReplayPipelineOptions live_pipeline_options(const Args& args) {
  ReplayPipelineOptions o;
  o.two_core = args.has("two-core");  // the estimator on a third thread
  return o;
}

}  // namespace

int run_live(const std::vector<std::string>& argv, std::ostream& out, std::ostream& err) {
  const Args args("live", argv, with_mavlink_flags({"quiet", "loop", "no-tight-relocation", "two-core"}),
                  with_mavlink_valued({"config", "source", "out", "seconds", "duration", "vocabulary", "load-map",
                                       "save-map", "map-spread-s"}));
  args.require_positionals(0, "");
  const std::filesystem::path out_dir = args.get_or("out", "out/live");
  const std::string source = args.get_or("source", "d455");
  const double seconds = args.get_double("seconds", 0.0);
  std::unique_ptr<LiveSource> src = open_source(args, source, err);
  if (src == nullptr) return kExitFailure;
  const AppConfig& config = src->config;
  std::filesystem::create_directories(out_dir);

  AllocScope startup_allocs;
  ReplayPipeline pipeline(config, live_pipeline_options(args));
  pipeline.set_static_bytes(static_cast<std::size_t>(startup_allocs.bytes()) + sizeof(ReplayPipeline));
  auto bridge = std::make_unique<d455::ThreadBridge>(config.rig.cam[0].width, config.rig.cam[0].height);
  LivePoseFiles files = open_pose_files(out_dir, pipeline);
  std::unique_ptr<MavlinkSession> mavlink = mavlink_from_args(args, config, out_dir);
  // Live: a frame never waits for loop closure (a keyframe the loop thread cannot take is counted).
  std::unique_ptr<LoopSession> loop = loop_from_args(args, config, out_dir, LoopThreading{false, QueueFull::kDrop});
  if (loop != nullptr) loop->attach(pipeline);
  attach_mavlink(mavlink.get(), loop.get(), pipeline);
  const BackendStopper stop_backend_first{&pipeline};  // --two-core: before loop and mavlink go

  const ProducerResult producer = run_threads(*src, *bridge, pipeline, seconds);
  pipeline.end_of_input();
  const bool poses_ok = close_pose_files(&files, pipeline);
  const ReplaySummary summary = pipeline.summary();
  JsonWriter w;
  w.begin_object();
  w.value("version", version_string());
  w.value("source", source);
  pipeline.write_stats(w);
  finish_mavlink(mavlink.get(), pipeline, w, out_dir, err);
  // An output that could not be written: exit 1 after the rest.
  const bool failed_write = !finish_loop(loop.get(), pipeline, w, err);
  w.begin_object("bridge")
      .value("imu_dropped", bridge->imu_dropped())
      .value("frames_dropped", bridge->frames_dropped())
      .end_object();
  w.end_object();
  write_text(out_dir / "stats.json", w.str());

  out << "live: " << summary.frames << " stereo pairs, " << summary.imu_samples << " IMU samples from "
      << source << "; ring overflows: " << bridge->frames_dropped() << " frames, " << bridge->imu_dropped()
      << " IMU samples\n";
  pipeline.print_summary(out);
  out << "live: " << pipeline.poses_written() << " poses in " << files.trajectory_path.string()
      << ", IMU-rate poses in " << files.imu_path.string() << "\n";
  if (!poses_ok) {
    err << "umsvins live: writing the pose files failed (disk full?)\n";
    return kExitFailure;
  }
  if (producer.status != Status::kOk) {
    err << "umsvins live: " << producer.error << "\n";
    return kExitFailure;
  }
  return failed_write ? kExitFailure : kExitOk;
}

}  // namespace ums::cli
