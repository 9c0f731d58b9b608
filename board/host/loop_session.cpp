#include "board/host/loop_session.hpp"

#include <cerrno>
#include <cstring>
#include <fstream>
#include <iterator>
#include <sstream>
#include <stdexcept>
#include <vector>

#include "board/host/builtin_vocabulary.hpp"
#include "board/host/cli_args.hpp"
#include "board/host/replay_pipeline.hpp"
#include "core/estimator/estimator.hpp"
#include "core/loop/final_map_poses.hpp"

namespace ums::cli {

loop::Vocabulary read_vocabulary(const std::filesystem::path& path) {
  if (path.empty()) return loop::Vocabulary::parse(builtin_vocabulary_bytes(), kBuiltinVocabularyName);
  std::ifstream in(path, std::ios::binary);
  if (!in) throw std::runtime_error(path.string() + ": cannot open the vocabulary");
  const std::vector<std::uint8_t> bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  return loop::Vocabulary::parse(bytes, path.string());
}

LoopSession::LoopSession(const std::filesystem::path& vocabulary, const loop::LoopOptions& options, const AppConfig& config,
                         const std::filesystem::path& out_dir)
    : out_dir_(out_dir),
      map_path_(out_dir / "trajectory_map.tum"),
      live_path_(out_dir / "trajectory_map_live.tum"),
      vocabulary_path_(vocabulary.empty() ? std::string(kBuiltinVocabularyName) : vocabulary.string()),
      vocabulary_(read_vocabulary(vocabulary)),
      closer_(std::make_unique<loop::LoopCloser>(options, config.rig, vocabulary_)) {
  live_file_ = std::fopen(live_path_.c_str(), "w");
  if (live_file_ == nullptr) throw std::runtime_error(live_path_.string() + ": cannot open for writing");
  std::fputs("# t_s x y z qx qy qz qw (body = IMU in the map frame as flown: T_map_odom * T_odom_b with the map "
             "frame known at each frame's time; umsvins)\n", live_file_);
  // No trajectory_map.tum of an earlier run may stand beside this run's outputs until finish().
  std::error_code ignored;
  std::filesystem::remove(map_path_, ignored);
  // The odometry per frame, read back at the end for trajectory_map.tum: a file, not memory (a
  // flight of any length), in the output folder (a board's /tmp may be small or read-only),
  // unlinked at once so that nothing is left behind whatever happens.
  const std::filesystem::path frames_path = out_dir / ".trajectory_map.frames";
  frames_ = std::fopen(frames_path.c_str(), "w+b");
  if (frames_ == nullptr) throw std::runtime_error(frames_path.string() + ": cannot open for writing: " + std::strerror(errno));
  std::filesystem::remove(frames_path, ignored);
}

void LoopSession::run_on_thread(QueueFull when_full) {
  worker_ = std::make_unique<LoopWorker>(*closer_, *closer_, when_full);
}

const loop::MapFrameSource& LoopSession::source() const {
  if (worker_ != nullptr) return *worker_;
  return *closer_;
}

PoseSink* LoopSession::map_frame(PoseSink* next) {
  map_frame_ = std::make_unique<loop::MapFramePoses>(source(), next, spread_s_);
  return map_frame_.get();
}

void LoopSession::load_map(const std::filesystem::path& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw std::runtime_error(path.string() + ": cannot open the map");
  const std::vector<std::uint8_t> bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  closer_->load_map(bytes, path.string());
  loaded_map_path_ = path.string();
}

LoopSession::~LoopSession() {
  if (worker_ != nullptr) worker_->stop();
  if (live_file_ != nullptr) std::fclose(live_file_);
  if (frames_ != nullptr) std::fclose(frames_);
}

void LoopSession::attach(ReplayPipeline& pipeline) {
  if (worker_ != nullptr) {
    pipeline.set_keyframe_image_sink(worker_.get());
    pipeline.set_keyframe_sink(worker_.get());
    pipeline.set_relocation_link(worker_.get());
  } else {
    pipeline.set_keyframe_image_sink(closer_.get());
    pipeline.set_keyframe_sink(closer_.get());
    pipeline.set_relocation_link(closer_.get());
  }
  pipeline.set_map_pose_consumer(this);
}

void LoopSession::detach(ReplayPipeline& pipeline) {
  pipeline.set_keyframe_image_sink(nullptr);
  pipeline.set_keyframe_sink(nullptr);
  pipeline.set_relocation_link(nullptr);
  pipeline.set_map_pose_consumer(nullptr);
}

namespace {

// One frame's odometry in the temporary file.
struct FrameRecord {
  std::int64_t t_ns;
  std::uint32_t epoch;
  double p[3];
  double q[4];  // x y z w
};

void write_tum_line(std::FILE* f, std::int64_t t_ns, const Eigen::Vector3d& p, const Eigen::Quaterniond& q) {
  std::fprintf(f, "%lld.%09lld %.7f %.7f %.7f %.9f %.9f %.9f %.9f\n", static_cast<long long>(t_ns / 1000000000),
               static_cast<long long>(t_ns % 1000000000), p.x(), p.y(), p.z(), q.x(), q.y(), q.z(), q.w());
}

Eigen::Isometry3d pose_of(const FrameRecord& r) {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = Eigen::Quaterniond(r.q[3], r.q[0], r.q[1], r.q[2]).toRotationMatrix();
  T.translation() = Eigen::Vector3d(r.p[0], r.p[1], r.p[2]);
  return T;
}

}  // namespace

void LoopSession::on_frame_pose(const EstimatorOutput& out) {
  if (frames_ != nullptr) {
    const FrameRecord r{out.t_ns, out.odometry_epoch, {out.p_w_b.x(), out.p_w_b.y(), out.p_w_b.z()},
                        {out.q_w_b.x(), out.q_w_b.y(), out.q_w_b.z(), out.q_w_b.w()}};
    if (std::fwrite(&r, sizeof(r), 1, frames_) != 1) frames_failed_ = true;
  }
  Eigen::Isometry3d T_map_odom;
  if (live_file_ == nullptr || !source().map_from_odometry(out.odometry_epoch, &T_map_odom)) return;
  write_tum_line(live_file_, out.t_ns, T_map_odom * out.p_w_b,
                 Eigen::Quaterniond(T_map_odom.linear() * out.q_w_b.toRotationMatrix()).normalized());
  ++live_poses_;
}

std::string LoopSession::write_final_map() {
  if (frames_ == nullptr || frames_failed_ || std::fflush(frames_) != 0) return "the temporary file of the map trajectory: write failed";
  loop::FinalMapPoses final_map(closer_->database());
  FrameRecord r{};
  std::FILE* f = std::fopen(map_path_.c_str(), "w");
  if (f == nullptr) return map_path_.string() + ": " + std::strerror(errno);
  std::fputs("# t_s x y z qx qy qz qw (body = IMU in the final map: every frame placed through its keyframes' "
             "optimized map poses; umsvins)\n", f);
  std::rewind(frames_);
  while (std::fread(&r, sizeof(r), 1, frames_) == 1) {
    Eigen::Isometry3d T_map_b;
    if (!final_map.map_pose(r.t_ns, r.epoch, pose_of(r), &T_map_b)) continue;
    write_tum_line(f, r.t_ns, T_map_b.translation(), Eigen::Quaterniond(T_map_b.linear()).normalized());
    ++map_poses_;
  }
  const bool read_ok = std::ferror(frames_) == 0;
  const bool write_ok = std::ferror(f) == 0;
  if (std::fclose(f) != 0 || !write_ok) return map_path_.string() + ": write failed";
  return read_ok ? "" : "the temporary file of the map trajectory: read failed";
}

std::string LoopSession::finish() {
  auto failed = [](const std::filesystem::path& p) { return p.string() + ": " + std::strerror(errno); };
  if (worker_ != nullptr) {  // the queued keyframes first: the outputs below are the closer's
    worker_->stop();
    worker_stats_ = worker_->stats();
  }
  std::string error;
  if (live_file_ != nullptr) {
    if (std::fclose(live_file_) != 0) error = failed(live_path_);
    live_file_ = nullptr;
  }
  const std::string map_error = write_final_map();
  if (error.empty()) error = map_error;
  const std::filesystem::path loops_path = out_dir_ / "loops.csv";
  std::ofstream csv(loops_path);
  csv << "# t_query_s,t_loop_s,query_frame,loop_frame,inliers,correction_m,correction_deg,relocalization,"
         "x,y,z,qx,qy,qz,qw,sigma_p_m,sigma_rot_deg,refined (T_loop_query: the query's body in the loop keyframe's "
         "body frame, and its 1-sigma; refined 1: by the window, tightly coupled relocation)\n";
  char line[400];
  for (std::size_t i = 0; i < closer_->num_events(); ++i) {
    const loop::LoopEvent& e = closer_->event(i);
    const Eigen::Vector3d t = e.T_loop_query.translation();
    const Eigen::Quaterniond q(e.T_loop_query.linear());
    std::snprintf(line, sizeof(line), "%lld.%09lld,%lld.%09lld,%u,%u,%d,%.5f,%.4f,%d,%.6f,%.6f,%.6f,%.8f,%.8f,%.8f,%.8f,%.5f,%.4f,%d\n",
                  static_cast<long long>(e.t_query_ns / 1000000000), static_cast<long long>(e.t_query_ns % 1000000000),
                  static_cast<long long>(e.t_loop_ns / 1000000000), static_cast<long long>(e.t_loop_ns % 1000000000),
                  e.query, e.loop, e.inliers, e.correction_m, e.correction_deg, e.relocalization ? 1 : 0,
                  t.x(), t.y(), t.z(), q.x(), q.y(), q.z(), q.w(), e.sigma_p_m, e.sigma_rot_deg, e.refined ? 1 : 0);
    csv << line;
  }
  csv.flush();
  if (!csv && error.empty()) error = failed(loops_path);
  if (!save_map_path_.empty()) {
    const std::vector<std::uint8_t> bytes = closer_->save_map();
    std::ofstream map(save_map_path_, std::ios::binary);
    map.write(reinterpret_cast<const char*>(bytes.data()), static_cast<std::streamsize>(bytes.size()));
    map.flush();
    if (map) saved_map_bytes_ = bytes.size();
    if (!map && error.empty()) error = failed(save_map_path_);
  }
  return error;
}

void LoopSession::write_stats(JsonWriter& w) const {
  const loop::LoopStats& s = closer_->stats();
  w.begin_object("loop")
      .value("enabled", true)
      .value("vocabulary", vocabulary_path_)
      .value("vocabulary_checksum", static_cast<std::uint64_t>(vocabulary_.checksum()))
      .value("keyframes", static_cast<std::uint64_t>(closer_->database().size()))
      .value("keyframes_in", s.keyframes_in)
      .value("keyframes_not_levelled", s.keyframes_not_levelled)
      .value("keyframes_without_image", s.keyframes_without_image)
      .value("keyframes_not_indexed", s.keyframes_not_indexed)
      .value("keyframes_decimated", s.keyframes_decimated)
      .value("index_full", s.index_full)
      .value("sessions", s.sessions)
      .value("queries", s.queries)
      .value("queries_skipped", s.queries_skipped)
      .value("loop_edges_retired", s.loop_edges_retired)
      .value("events_overwritten", s.events_overwritten)
      .value("candidates", s.candidates)
      .value("accepted", s.accepted)
      .value("relocalizations", s.relocalizations)
      .value("tight_relocation", closer_->options().tight_relocation)
      .value("relocation_requests", s.relocation_requests)
      .value("relocations_refined", s.relocations_refined)
      .value("relocation_too_few", s.relocation_too_few)
      .value("relocation_too_far", s.relocation_too_far)
      .value("relocation_refused", s.relocation_refused)
      .value("relocation_stale", s.relocation_stale)
      .value("relocation_mean_change_m", s.relocations_refined > 0 ? s.relocation_change_m_sum / static_cast<double>(s.relocations_refined) : 0.0, 5);
  w.begin_object("rejected_by");
  for (int g = 0; g < static_cast<int>(loop::LoopGate::kCount); ++g) {
    w.value(loop::to_string(static_cast<loop::LoopGate>(g)), s.rejected_by[g]);
  }
  w.end_object();
  w.value("corrections", static_cast<std::uint64_t>(closer_->corrections()))
      .value("max_correction_m", s.max_correction_m, 4)
      .value("max_pose_graph_ms", s.max_pose_graph_ms, 3)
      .value("mean_describe_ms", s.described > 0 ? s.describe_ms_sum / static_cast<double>(s.described) : 0.0, 3)
      .value("max_describe_ms", s.max_describe_ms, 3)
      .value("mean_keyframe_ms", s.keyframes_in > 0 ? s.keyframe_ms_sum / static_cast<double>(s.keyframes_in) : 0.0, 3)
      .value("max_keyframe_ms", s.max_keyframe_ms, 3)
      .value("map_poses", map_poses_)
      .value("map_live_poses", live_poses_)
      .value("loaded_map", loaded_map_path_)
      .value("loaded_keyframes", static_cast<std::uint64_t>(closer_->loaded_keyframes()))
      .value("saved_map", save_map_path_.string())
      .value("saved_map_bytes", static_cast<std::uint64_t>(saved_map_bytes_))
      .value("peak_bytes", static_cast<std::uint64_t>(closer_->footprint_bytes() +
                                                      (worker_ != nullptr ? capacity::kLoopQueue * sizeof(loop::LoopKeyframe) : 0)))
      .value("thread", worker_ != nullptr)
      .value("thread_queued", worker_stats_.queued)
      .value("thread_dropped", worker_stats_.dropped)
      .value("thread_waits", worker_stats_.waits)
      .value("thread_max_depth", worker_stats_.max_depth)
      .value("thread_relocation_results_dropped", worker_stats_.relocation_results_dropped)
      .end_object();
}

bool finish_loop(LoopSession* loop, ReplayPipeline& pipeline, JsonWriter& w, std::ostream& err) {
  if (loop == nullptr) {
    w.begin_object("loop").value("enabled", false).end_object();
    return true;
  }
  loop->detach(pipeline);
  const std::string error = loop->finish();
  if (!error.empty()) err << "umsvins: " << error << "\n";
  loop->write_stats(w);
  return error.empty();
}

std::unique_ptr<LoopSession> loop_from_args(const Args& args, const AppConfig& config,
                                            const std::filesystem::path& out_dir, LoopThreading threading) {
  const std::optional<std::string> vocabulary = args.get("vocabulary");
  if (!vocabulary && !args.has("loop")) {
    if (args.get("load-map") || args.get("save-map") || args.get("map-spread-s") || args.has("no-tight-relocation")) {
      throw UsageError("umsvins: --load-map, --save-map, --map-spread-s and --no-tight-relocation need --loop or "
                       "--vocabulary (loop closure)");
    }
    return nullptr;
  }
  if (vocabulary && vocabulary->empty()) throw UsageError("umsvins: --vocabulary needs a file");
  loop::LoopOptions options;
  options.tight_relocation = !args.has("no-tight-relocation");
  auto session = std::make_unique<LoopSession>(vocabulary.value_or(""), options, config, out_dir);
  if (const auto load = args.get("load-map")) session->load_map(*load);
  if (const auto save = args.get("save-map")) session->save_map_to(*save);
  const double spread_s = args.get_double("map-spread-s", 0.0);
  if (!(spread_s >= 0.0 && spread_s <= 60.0)) throw UsageError("umsvins: --map-spread-s must be in [0, 60] s");
  session->set_map_spread_s(spread_s);
  if (!threading.same_thread) session->run_on_thread(threading.when_full);
  return session;
}

}  // namespace ums::cli
