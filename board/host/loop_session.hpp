#pragma once
// Loop closure in a replay or a live run: the vocabulary read from its file, the LoopCloser fed
// by the pipeline's keyframes, and its outputs: trajectory_map_live.tum (T_map_odom * T_odom_b
// per frame as flown, with the map frame known at the frame's time: what the MAVLink output
// sent), trajectory_map.tum (written at the end: every frame placed through the final map's
// keyframes, core/loop/final_map_poses.hpp), loops.csv (every accepted loop with its size) and
// stats.json's "loop" object. trajectory.tum stays the continuous odometry.
//
// Flags: --loop turns loop closure on with the built-in vocabulary, --vocabulary F with that one
// (neither: no loop closure, the outputs are not written and stats.json says "loop":
// {"enabled": false}). --load-map F starts from a map
// saved by an earlier run (the run joins it at its first verified loop); --save-map F writes the
// map at the end. Both need --vocabulary.
//
// Threads: with run_on_thread() the closer's costly step runs on its own thread (LoopWorker);
// without it everything runs on the frame thread, so --deterministic replays stay identical.

#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <memory>
#include <ostream>
#include <string>

#include "board/config/app_config.hpp"
#include "board/host/loop_worker.hpp"
#include "core/loop/loop_closer.hpp"
#include "core/loop/map_frame_poses.hpp"
#include "core/loop/vocabulary.hpp"
#include "core/pipeline/pose_sink.hpp"
#include "profiling/json_writer.hpp"

namespace ums::cli {

class Args;
class ReplayPipeline;

// Reads and parses a vocabulary file ("" : the built-in one); std::runtime_error naming the file
// and the reason.
loop::Vocabulary read_vocabulary(const std::filesystem::path& path);

class LoopSession final : public PoseSink {
 public:
  // vocabulary: a file, or "" for the built-in one.
  LoopSession(const std::filesystem::path& vocabulary, const loop::LoopOptions& options, const AppConfig& config,
              const std::filesystem::path& out_dir);
  // Start-up, before the first keyframe: std::runtime_error naming the file and the reason.
  void load_map(const std::filesystem::path& path);
  // Written by finish().
  void save_map_to(const std::filesystem::path& path) { save_map_path_ = path; }
  ~LoopSession() override;
  LoopSession(const LoopSession&) = delete;
  LoopSession& operator=(const LoopSession&) = delete;

  // Before attach(): the loop work after the keyframe images on its own thread.
  void run_on_thread(QueueFull when_full);
  // Connects the closer to the pipeline's keyframes and this to its poses.
  void attach(ReplayPipeline& pipeline);
  void detach(ReplayPipeline& pipeline);

  void on_frame_pose(const EstimatorOutput& out) override;
  void on_imu_pose(std::int64_t, const NavState&) override {}
  // Where the map frame is read from: the worker's published placement, or the closer.
  const loop::MapFrameSource& source() const;

  // Closes trajectory_map_live.tum, writes trajectory_map.tum, loops.csv and the map file (--save-map); "" or what failed
  // ("<file>: <reason>").
  std::string finish();
  void write_stats(JsonWriter& w) const;
  const loop::LoopCloser& closer() const { return *closer_; }
  // A consumer of the poses in the map frame (loop/map_frame_poses.hpp): pass the returned sink
  // to the pipeline instead of `next`.
  PoseSink* map_frame(PoseSink* next);
  // --map-spread-s: corrections to the live output spread over this many seconds (0: a step).
  void set_map_spread_s(double spread_s) { spread_s_ = spread_s; }
  std::uint64_t map_poses() const { return map_poses_; }
  // trajectory_map.tum, complete after finish().
  const std::filesystem::path& map_trajectory_path() const { return map_path_; }

 private:
  std::filesystem::path out_dir_;
  std::filesystem::path map_path_;
  std::filesystem::path live_path_;
  std::string vocabulary_path_;
  std::string loaded_map_path_;
  std::filesystem::path save_map_path_;
  std::size_t saved_map_bytes_ = 0;
  loop::Vocabulary vocabulary_;
  std::unique_ptr<loop::LoopCloser> closer_;
  std::unique_ptr<LoopWorker> worker_;
  LoopWorkerStats worker_stats_;
  std::unique_ptr<loop::MapFramePoses> map_frame_;
  std::FILE* live_file_ = nullptr;
  std::FILE* frames_ = nullptr;  // FrameRecords (loop_session.cpp), a temporary file
  bool frames_failed_ = false;
  std::uint64_t live_poses_ = 0;
  std::uint64_t map_poses_ = 0;
  std::string write_final_map();
  double spread_s_ = 0.0;
};

// At the end of a run: detaches the session, finishes its outputs and writes stats.json's "loop"
// ({"enabled": false} without a session). false when an output failed (said on err).
bool finish_loop(LoopSession* loop, ReplayPipeline& pipeline, JsonWriter& w, std::ostream& err);

// The session asked for by --vocabulary, or nullptr; its loop work on a thread unless
// `same_thread` (--deterministic), a live run dropping keyframes the thread cannot take.
struct LoopThreading {
  bool same_thread = false;
  QueueFull when_full = QueueFull::kWait;
};
std::unique_ptr<LoopSession> loop_from_args(const Args& args, const AppConfig& config,
                                            const std::filesystem::path& out_dir, LoopThreading threading);

}  // namespace ums::cli
