#pragma once
// Loop closure (the paper's Sec. III-C, second half; docs/loop-closure.md): fed by the pipeline's
// keyframe images and the estimator's marginalized keyframes, it keeps the keyframe database,
// asks place recognition for candidates, verifies them through a chain of gates (each rejection
// counted), and on an accepted loop solves the 4-DoF pose graph and moves the map frame:
// T_map_b = T_map_odom * T_odom_b. The odometry itself is never changed.
//
// Keyframe images arrive when a frame becomes a keyframe; the keyframe leaves the window some
// frames later. In between, its left features' descriptors wait in a small ring (described at
// the tracked positions, once per keyframe); when it leaves, those of its 3D landmarks with a
// depth are kept. Sessions: an estimator reset starts a new odometry frame; its keyframes join the
// map only through a verified loop (relocalization), and until then it has no map pose.
//
// Everything is allocated at construction. The work is per keyframe, never per frame, in two
// steps: prepare() picks the leaving keyframe's described 3D features (cheap, on the thread that
// feeds the sinks), add_keyframe() keeps, queries, verifies and solves (the costly part). As a
// KeyframeSink the closer runs both where it is called (--deterministic runs stay identical);
// board/host/loop_worker runs the second on its own thread.

#include <algorithm>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include <Eigen/Geometry>

#include "core/common/calibration.hpp"
#include "core/estimator/keyframe_sink.hpp"
#include "core/frontend/frame_features.hpp"
#include "core/loop/brief.hpp"
#include "core/loop/inverted_index.hpp"
#include "core/loop/keyframe_database.hpp"
#include "core/loop/loop_steps.hpp"
#include "core/loop/loop_verifier.hpp"
#include "core/loop/map_frame_source.hpp"
#include "core/loop/pose_graph.hpp"
#include "core/loop/vocabulary.hpp"
#include "core/pipeline/keyframe_image_sink.hpp"

namespace ums::loop {

struct LoopOptions {
  double recent_s = 20.0;              // s, candidates must be older than this (not the same pass)
  int candidates = 3;                  // best index hits verified per query
  int min_features = 30;               // 3D features for a keyframe to be indexed and queried
  float min_score = 0.01f;             // L1 score of a candidate
  float min_normalized_score = 0.2f;   // candidate score / score against the previous keyframe
  int min_inliers = 25;                // after PnP (VINS-Mono: 25)
  double min_inlier_ratio = 0.35;      // inliers / descriptor matches
  double max_gravity_deg = 3.0;        // roll/pitch disagreement of the loop with both keyframes
  double drift_base_m = 0.3;           // drift budget: base + per metre flown between the two
  double drift_per_m = 0.05;
  double drift_base_deg = 3.0;
  double drift_per_m_deg = 0.3;
  int protected_recent = 60;           // newest keyframes decimation never drops
  double loop_interval_s = 1.0;        // s, no query for this long after an accepted loop
  // Pose-graph odometry edge between consecutive keyframes: base + per metre between them
  // (VIO drifts well under 1 % of the distance; a loop must not bend the odometry locally). The
  // base is per keyframe (tens of ms apart): larger, it random-walks to centimetres over a hover
  // of a few hundred keyframes, which VIO does not drift, and every loop's noise bends the map.
  double odom_sigma_p_m = 0.0005;
  double odom_sigma_p_per_m = 0.01;
  double odom_sigma_yaw_deg = 0.005;
  double odom_sigma_yaw_deg_per_m = 0.1;
  // An odometry edge touching a keyframe with fewer than min_features 3D features was flown on
  // the IMU (vision lost: dark, blackout): its sigmas times this, so the first loop afterwards
  // moves the map to where the images say instead of trusting the dead reckoning.
  double blind_sigma_scale = 100.0;
  // ... and its position sigma grows as sqrt(1 + t / blind_drift_time_s), t the time from the start
  // of the blind stretch to the edge: the dead reckoning's velocity error, and so the drift per
  // edge, grows from what VIO left (~0.01-0.02 m/s) by the accelerometer bias and tilt error
  // (~0.01-0.02 m/s^2), doubling in about a second.
  double blind_drift_time_s = 1.0;
  // A loop edge's sigmas: the verifier's 1-sigma of the measured pose (from its fit's information
  // and residual variance; V102: errors against ground truth 1.6 sigma on average, as a 3D
  // Gaussian's norm should be) times loop_sigma_fit_scale, at least the floors. Loops read from a
  // map file keep no sigma: loop_sigma_p_m and loop_sigma_yaw_deg.
  double loop_sigma_fit_scale = 1.5;
  double loop_sigma_min_p_m = 0.002;
  double loop_sigma_min_yaw_deg = 0.02;
  double loop_sigma_p_m = 0.03;
  double loop_sigma_yaw_deg = 0.5;
  // After the solve, a new loop edge left further than this (in its sigmas) from the solved poses
  // is refused (gate pose_graph): the graph could only hold it off under the robust loss.
  double max_loop_residual_sigma = 5.0;
  // Tightly coupled relocation (core/estimator/relocation.hpp): an accepted loop's inlier
  // landmarks go to the window, whose solve measures the loop again. When enough of those
  // landmarks fit (min_relocation_inliers) and the window's measurement stays within
  // relocation_max_change_{m,deg} of the verified one (a larger change means the window's
  // landmarks and the loop keyframe disagree: the verified one is kept), the loop edge takes
  // their blend: relocation_blend of the window's (0.5: equal weights; on the 7 whole flights the
  // window's alone measures no better than the verifier, 10-30 % worse against ground truth).
  bool tight_relocation = true;
  double relocation_blend = 0.5;
  int min_relocation_inliers = 12;
  double relocation_max_change_m = 0.05;
  double relocation_max_change_deg = 1.0;
  LoopVerifierOptions verifier;
  // Loop edges passed the gates (the drift budget among them): the robust loss only guards
  // against a loop far beyond them, 10 sigma = 0.3 m.
  PoseGraphOptions graph = [] {
    PoseGraphOptions g;
    g.loop_loss_scale = 10.0;
    return g;
  }();
  void validate() const;               // std::invalid_argument naming the field
};

// Why a candidate was refused (index into LoopStats::rejected_by).
enum class LoopGate : std::uint8_t {
  kScore = 0, kMatches, kInliers, kInlierRatio, kGravity, kDriftBudget, kPoseGraph, kCount
};
const char* to_string(LoopGate g);

struct LoopStats {
  std::uint64_t keyframes_in = 0;          // marginalized keyframes received
  std::uint64_t keyframes_not_levelled = 0; // from a frame not levelled to gravity (not kept)
  std::uint64_t keyframes_without_image = 0;  // no descriptors waiting for them (not indexed)
  std::uint64_t keyframes_not_indexed = 0; // fewer than min_features 3D features
  std::uint64_t keyframes_decimated = 0;   // dropped by the full-database policy
  std::uint64_t index_full = 0;            // postings pool full (not indexed)
  std::uint64_t queries = 0;
  std::uint64_t queries_skipped = 0;       // within loop_interval_s of an accepted loop
  std::uint64_t loop_edges_retired = 0;    // oldest loop edges dropped for new ones (kMaxLoopEdges)
  std::uint64_t events_overwritten = 0;    // accepted loops no longer in the event log
  std::uint64_t keyframes_dropped = 0;     // database full and nothing may be decimated: not kept
  std::uint64_t candidates = 0;            // index hits examined
  std::uint64_t accepted = 0;
  std::uint64_t relocalizations = 0;       // accepted loops that joined a new session to the map
  // Tightly coupled relocation: requests made, loops refined by the window, and the results not
  // used: too few of the landmarks in the window or fitting, too large a change, refused by the
  // pose graph, or the loop edge gone (retired) before the result came.
  std::uint64_t relocation_requests = 0;
  std::uint64_t relocations_refined = 0;
  std::uint64_t relocation_too_few = 0;
  std::uint64_t relocation_too_far = 0;
  std::uint64_t relocation_refused = 0;
  std::uint64_t relocation_stale = 0;
  double relocation_change_m_sum = 0.0;    // |refined - verified| over the refined loops
  std::uint64_t rejected_by[static_cast<int>(LoopGate::kCount)] = {};
  std::uint64_t sessions = 0;              // odometry frames (resets) that reached the database
  double max_correction_m = 0.0;           // largest change of the newest keyframe's map pose
  double max_pose_graph_ms = 0.0;
  // Wall time of the loop work per keyframe (describing its image; keeping, querying, verifying,
  // and the pose graph when a loop closes), ms.
  double keyframe_ms_sum = 0.0;
  double max_keyframe_ms = 0.0;
  std::uint64_t described = 0;             // keyframe images described
  double describe_ms_sum = 0.0;
  double max_describe_ms = 0.0;
};

struct LoopEvent {
  std::int64_t t_query_ns = 0, t_loop_ns = 0;
  FrameId query = kNoFrame, loop = kNoFrame;
  int inliers = 0;
  double correction_m = 0.0, correction_deg = 0.0;  // change of the map pose of the query keyframe
  bool relocalization = false;
  Eigen::Isometry3d T_loop_query = Eigen::Isometry3d::Identity();  // measured, body frames
  // m, the two keyframes' bodies in the map frame once the loop closed (for plots)
  Eigen::Vector3d p_map_query = Eigen::Vector3d::Zero(), p_map_loop = Eigen::Vector3d::Zero();
  double sigma_p_m = 0.0, sigma_rot_deg = 0.0;  // the measured pose's uncertainty (LoopGeometry's)
  bool refined = false;  // T_loop_query is the window's refinement (tightly coupled relocation)
};

class LoopCloser final : public KeyframeSink, public KeyframeImageSink, public MapFrameSource, public LoopSteps {
 public:
  // vocabulary: not owned, outlives the closer. Throws std::invalid_argument on bad options.
  LoopCloser(const LoopOptions& options, const RigCalibration& rig, const Vocabulary& vocabulary);
  ~LoopCloser() override;
  LoopCloser(const LoopCloser&) = delete;
  LoopCloser& operator=(const LoopCloser&) = delete;

  void on_keyframe_image(FrameId id, std::int64_t t_ns, const ImageView& left,
                         const FrameFeatures& features) override;
  // prepare() then add_keyframe(), here. Keyframes of a frame not levelled to gravity (VO) are
  // not kept: a 4-DoF map needs gravity.
  void on_keyframe(const MarginalizedKeyframe& keyframe) override;
  // The keyframe's 3D features that have descriptors waiting (on the thread of
  // on_keyframe_image, before kWindowSize more keyframe images arrive).
  void prepare(const MarginalizedKeyframe& keyframe, LoopKeyframe* out) const override;
  // Keeps the keyframe, queries, verifies and closes a loop (any thread, one at a time).
  void add_keyframe(const LoopKeyframe& keyframe) override;
  // Tightly coupled relocation (on add_keyframe's thread): the last accepted loop's request, and
  // the window's result, which replaces the loop's measurement and solves the graph again.
  bool take_relocation(RelocationRequest* out) override;
  void on_relocated(const RelocationResult& result) override;
  MapPlacement placement() const override {
    return MapPlacement{started_, epoch_, session_placed_, T_map_odom_, corrections_};
  }

  // T_map_odom of the odometry frame of epoch `odometry_epoch` (EstimatorOutput's); false while
  // that frame is not placed in the map (not levelled yet, or a new frame not yet relocalized).
  bool map_from_odometry(std::uint32_t odometry_epoch, Eigen::Isometry3d* T_map_odom) const override;
  // Incremented by every change of T_map_odom (MAVLink's reset_counter).
  std::uint32_t corrections() const override { return corrections_; }

  const LoopStats& stats() const { return stats_; }
  const LoopOptions& options() const { return options_; }
  // The accepted loops, oldest first: the newest kMaxLoopEvents (stats().events_overwritten more
  // were accepted before them).
  std::size_t num_events() const { return std::min(n_events_, capacity::kMaxLoopEvents); }
  const LoopEvent& event(std::size_t i) const {
    const std::size_t first = n_events_ > capacity::kMaxLoopEvents ? n_events_ - capacity::kMaxLoopEvents : 0;
    return events_[(first + i) % capacity::kMaxLoopEvents];
  }
  const KeyframeDatabase& database() const { return *db_; }

  // Map reuse: the keyframes placed in the map (poses, features, loops) as the bytes of a
  // versioned file (magic, version, vocabulary checksum, calibration hash, counts, records, a
  // CRC-32). Allocates: at shut-down only.
  std::vector<std::uint8_t> save_map() const;
  // Loads save_map()'s bytes into this closer before its first keyframe: the map's keyframes
  // become the map frame, and the run's odometry is placed in it by its first verified loop.
  // Throws std::runtime_error "<source>: not a usable map: <why>" (corrupt, truncated, another
  // vocabulary or camera, over the capacities, not a fresh closer) and then changes nothing.
  void load_map(const std::vector<std::uint8_t>& bytes, const std::string& source);
  std::size_t loaded_keyframes() const { return loaded_keyframes_; }
  // CRC-32 of the calibration values that descriptors and points depend on (both cameras'
  // model, size, intrinsics, distortion and pose in the IMU frame at 1e-6).
  std::uint32_t calibration_hash() const { return calibration_hash_; }
  std::size_t footprint_bytes() const;

 private:
  static constexpr std::size_t kPending = capacity::kWindowSize + 4;
  struct Pending;

  void describe(FrameId id, const ImageView& left, const FrameFeatures& features);
  void keep(const LoopKeyframe& k);
  void build_record(const LoopKeyframe& k, std::uint32_t slot);
  void make_room();
  void query(std::uint32_t slot);
  bool passes_gates(std::uint32_t q_slot, std::uint32_t c_slot, const LoopGeometry& g);
  bool close_loop(std::uint32_t q_slot, std::uint32_t c_slot, const LoopGeometry& g);
  bool solve_graph();
  struct OdometrySigmas {
    double p_m, yaw_rad;
  };
  // The sigmas of the odometry edge a -> b (consecutive, one session, d_m apart); blind_since_ns
  // carries the start of the blind stretch along the chain (-1: not in one).
  OdometrySigmas odometry_sigmas(const KeyframeRecord& a, const KeyframeRecord& b, double d_m,
                                 std::int64_t* blind_since_ns) const;
  // Sets T_map_odom (yaw and translation only) so that q sits at T_map_q, and marks q's session
  // placed or not, its keyframes' map poses with it.
  void place_session(const KeyframeRecord& q, const Eigen::Isometry3d& T_map_q, bool placed);
  void reject(LoopGate g) { ++stats_.rejected_by[static_cast<int>(g)]; }
  // Map files (loop_map.cpp).
  void check_map_header(const std::vector<std::uint8_t>& bytes, const std::string& source,
                        std::uint32_t* n_keyframes, std::uint32_t* n_loops) const;
  void read_map_records(const std::vector<std::uint8_t>& bytes, const std::string& source,
                        std::uint32_t n_keyframes, std::uint32_t n_loops, bool apply);
  void commit_loaded(std::uint32_t slot);

  LoopOptions options_;
  const Vocabulary& vocabulary_;
  Eigen::Isometry3d T_b_c0_;
  BriefDescriber describer_;
  LoopVerifier verifier_;
  std::unique_ptr<KeyframeDatabase> db_;
  std::unique_ptr<InvertedIndex> index_;
  std::unique_ptr<PoseGraph4Dof> graph_;
  std::unique_ptr<Pending[]> pending_;
  std::unique_ptr<LoopKeyframe> prepared_;      // on_keyframe's
  std::size_t pending_next_ = 0;
  std::unique_ptr<Descriptor[]> scratch_;       // one keyframe's descriptors, for the vocabulary
  std::unique_ptr<std::int32_t[]> node_of_;     // per database slot: its pose-graph node, or -1
  std::unique_ptr<std::uint32_t[]> slot_of_;    // per pose-graph node: its database slot
  struct LoopEdge {
    std::uint32_t c_slot, q_slot;
    Eigen::Isometry3d T_c_q;
    double sigma_p_m, sigma_yaw_rad;
  };
  std::unique_ptr<LoopEdge[]> loops_;
  // The map state before a loop's solve, restored when the loop is refused.
  struct SavedPose {
    Eigen::Isometry3d T_map_b;
    bool placed;
  };
  std::unique_ptr<SavedPose[]> saved_;  // per database slot
  Eigen::Isometry3d saved_T_map_odom_ = Eigen::Isometry3d::Identity();
  bool saved_session_placed_ = false;
  std::uint32_t saved_corrections_ = 0;
  void save_map_state();
  void restore_map_state();
  LoopEdge retire_oldest_loop();
  void unretire(const LoopEdge& edge);
  void request_relocation(const KeyframeRecord& q, const KeyframeRecord& c, const LoopGeometry& g);
  // The loop edge from keyframe `loop` to `query`, or -1.
  std::int32_t find_loop(FrameId query, FrameId loop) const;
  bool refine_loop(std::size_t l, const Eigen::Isometry3d& T_c_q);
  void note_refined(const RelocationResult& result, std::size_t l);
  double loop_residual_sigma(const LoopEdge& l) const;
  std::size_t n_loops_ = 0;
  std::unique_ptr<LoopEvent[]> events_;
  std::size_t n_events_ = 0;
  std::unique_ptr<RelocationRequest> request_;
  bool has_request_ = false;
  std::unique_ptr<std::uint16_t[]> pair_q_, pair_c_;  // inlier pairs for a request
  std::unique_ptr<std::uint32_t[]> newest_landmarks_;  // per feature of the newest kept keyframe
  std::uint32_t newest_slot_ = 0;                     // its database slot (the only query)
  void begin_session(std::uint32_t epoch);

  std::uint32_t session_ = 0;
  std::uint32_t epoch_ = 0;
  bool started_ = false;
  std::uint32_t calibration_hash_ = 0;
  std::size_t loaded_keyframes_ = 0;
  std::int64_t last_loop_t_ns_ = 0;
  bool any_loop_ = false;
  bool session_placed_ = false;  // the current session is placed in the map
  Eigen::Isometry3d T_map_odom_ = Eigen::Isometry3d::Identity();
  std::uint32_t corrections_ = 0;
  LoopStats stats_;
};

}  // namespace ums::loop
