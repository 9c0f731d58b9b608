#pragma once
// The estimator of the paper (Sec. III-B, III-C): a mode machine over a sliding window.
//
//   IMU_ONLY  case 1: no visual initialization yet (too few 3D features, e.g. dark images) or
//             vision lost: the pose comes from IMU propagation, attitude from gravity at rest or
//             the last estimate; zero velocity while the IMU says the rig is still.
//   VO        case 2 in progress or failed: stereo visual initialization succeeded (PnP with
//             RANSAC on bearings, then BA of poses and inverse depths); the window runs stereo +
//             2D features without the IMU while the visual-IMU alignment is retried.
//   VIO       case 3: aligned. Each frame: IMU prediction, the tightly coupled BA of eq. (4)
//             with the two-stage feature use, outlier removal, a second time-bounded round, then
//             marginalization (oldest when the new frame is a keyframe, else the second newest).
// Alignment (case 2): gyro bias from relative rotations, gravity and velocities by least squares
// (stereo fixes the scale), then the loosely coupled BA run twice, the second time from a start
// tilted by align_perturb_deg: if the two disagree on gravity or accelerometer bias the IMU did
// not observe them (e.g. uniform motion) and the estimator stays in VO. At rest the IMU gives
// gravity, zero velocity and the gyro bias directly (standstill start: initialized at once).
//
// Fixed memory: every buffer (window slots, landmark pool, residual objects, the solver problem
// and priors) is allocated in the constructor; add_imu / add_frame allocate nothing.

#include <cstdint>
#include <memory>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "core/common/calibration.hpp"
#include "core/common/capacity.hpp"
#include "core/common/fixed_vector.hpp"
#include "core/common/imu_sample.hpp"
#include "core/estimator/bearing_residual.hpp"
#include "core/estimator/estimator_options.hpp"
#include "core/estimator/frame_id.hpp"
#include "core/estimator/geometry.hpp"
#include "core/estimator/imu_factor.hpp"
#include "core/estimator/landmark.hpp"
#include "core/estimator/relative_pose_cache.hpp"
#include "core/estimator/state_residuals.hpp"
#include "core/frontend/frame_features.hpp"
#include "core/frontend/keyframe_selector.hpp"
#include "core/imu/preintegration.hpp"
#include "core/imu/propagation.hpp"
#include "core/imu/standstill.hpp"
#include "solver/capacity.hpp"

namespace ums {
namespace solver {
class Problem;
class MarginalPrior;
}  // namespace solver

enum class EstimatorMode : std::uint8_t { kImuOnly = 0, kVo = 1, kVio = 2 };

constexpr const char* to_string(EstimatorMode m) {
  switch (m) {
    case EstimatorMode::kImuOnly: return "IMU_ONLY";
    case EstimatorMode::kVo: return "VO";
    case EstimatorMode::kVio: return "VIO";
  }
  return "unknown";
}

// The estimate at one frame (camera rate).
struct EstimatorOutput {
  std::int64_t t_ns = 0;             // frame time, camera clock (the dataset's)
  FrameId frame_id = kNoFrame;       // the window frame this estimate belongs to
  EstimatorMode mode = EstimatorMode::kImuOnly;
  bool valid = false;                // a pose exists (attitude and velocity known)
  bool keyframe = false;
  Eigen::Vector3d p_w_b = Eigen::Vector3d::Zero();            // m
  Eigen::Quaterniond q_w_b = Eigen::Quaterniond::Identity();  // x,y,z,w in memory
  Eigen::Vector3d v_w_b = Eigen::Vector3d::Zero();            // m/s
  Eigen::Vector3d ba = Eigen::Vector3d::Zero();               // m/s^2
  Eigen::Vector3d bg = Eigen::Vector3d::Zero();               // rad/s
  int landmarks_in_solve = 0;
  int n_3d_used = 0, n_2d_left_used = 0, n_2d_right_used = 0;  // landmarks of each class solved
  bool still = false;                // the IMU said: at rest
};

// Wall time of the back-end stages of one frame (ms).
struct EstimatorTiming {
  float preintegrate_ms = 0.0f;   // closing the interval, whitening, standstill test
  float solve_round1_ms = 0.0f;   // the stage solves (3D / 3D+2D-left / all)
  float solve_round2_ms = 0.0f;   // after outlier removal, time-bounded
  float marginalize_ms = 0.0f;
  float backend_ms = 0.0f;        // the whole add_frame
};

struct ModeChange {
  std::int64_t t_ns = 0;
  EstimatorMode from = EstimatorMode::kImuOnly;
  EstimatorMode to = EstimatorMode::kImuOnly;
  const char* reason = "";        // static string
};

struct EstimatorStats {
  std::uint64_t frames = 0;
  std::uint64_t frames_in_mode[3] = {0, 0, 0};
  bool initialized = false;            // reached VIO
  std::int64_t first_frame_t_ns = -1;
  std::int64_t init_t_ns = -1;         // first time VIO was reached
  const char* init_case = "";          // "standstill" or "visual-imu alignment"
  FixedVector<ModeChange, 64> mode_changes;
  std::uint64_t mode_changes_dropped = 0;
  std::uint64_t visual_init_failures = 0;
  std::uint64_t align_attempts = 0;
  std::uint64_t align_failures = 0;     // any step of case 2 failed
  std::uint64_t align_disagreements = 0;  // the two loosely coupled BAs differed
  std::uint64_t solves = 0;
  std::uint64_t stage_kept_2d_left = 0;   // 3D vs 3D+2D-left agreed
  std::uint64_t stage_added_2d_right = 0; // disagreed or too few 3D: all classes
  std::uint64_t stage_3d_sufficient = 0;  // no 2D-left landmark to try: one stage
  std::uint64_t outlier_landmarks = 0;
  std::uint64_t second_rounds = 0;        // frames whose round 2 ran (outliers or not converged)
  std::uint64_t marginalized_old = 0;
  std::uint64_t marginalized_second_new = 0;
  std::uint64_t marginalization_failures = 0;
  std::uint64_t still_frames = 0;
  std::uint64_t still_rejected_by_vision = 0;  // IMU at rest but the images moved (uniform motion)
  std::uint64_t resets = 0;             // divergence or visual loss in VO
  double sum_landmarks_in_solve = 0.0;
  double sum_2d_in_solve = 0.0;         // 2D-left + 2D-right landmarks in the final solves
  std::uint64_t frames_solved = 0;
  std::size_t peak_landmarks = 0;       // landmark pool use
  std::size_t peak_residuals = 0;       // visual residual objects
  std::uint64_t drops_landmarks = 0;    // features not tracked: landmark pool full
  std::uint64_t drops_residuals = 0;    // observations not used: residual pool full
  std::uint64_t drops_imu = 0;          // IMU samples not integrated: interval buffer full
  std::uint64_t imu_out_of_order = 0;
  std::uint64_t imu_held = 0;             // saturated samples replaced by the previous one
  std::uint64_t frames_out_of_order = 0;
  std::uint64_t frames_without_pose = 0;  // IMU_ONLY before the velocity was ever known  // frames not after the previous one: not processed
};

class Estimator {
 public:
  // Start-up: validates options (std::invalid_argument), allocates every buffer.
  Estimator(const EstimatorOptions& options, const RigCalibration& rig);
  ~Estimator();
  Estimator(const Estimator&) = delete;
  Estimator& operator=(const Estimator&) = delete;

  // One IMU sample (time-ordered, after the saturation element; saturated: the element clipped
  // it, the previous sample is held instead). Allocates nothing.
  void add_imu(const ImuSample& sample, bool saturated = false);
  // One frame of features; writes the optimized pose at this frame. Allocates nothing.
  void add_frame(const FrameFeatures& features, EstimatorOutput* out, EstimatorTiming* timing);

  EstimatorMode mode() const { return mode_; }
  const EstimatorStats& stats() const { return stats_; }
  // The IMU-rate pose: the last frame's estimate propagated with every sample since.
  bool imu_rate_state(NavState* state) const;
  // Static footprint of this object and what it owns (bytes), for `umsvins budget`.
  std::size_t footprint_bytes() const;
  std::size_t landmark_capacity() const { return capacity::kMaxLandmarks; }
  std::size_t landmarks_in_use() const { return n_lm_index_; }

 private:
  struct FrameState {
    std::int64_t t_ns = 0;   // IMU clock
    double pose[7] = {0, 0, 0, 0, 0, 0, 1};
    double sb[9] = {0, 0, 0, 0, 0, 0, 0, 0, 0};
    Preintegration pre;      // previous window frame -> this one
    ImuFactor imu;
    bool imu_ok = false;
    bool keyframe = false;
    bool still = false;
  };
  struct Backup;
  static constexpr int kSlots = static_cast<int>(capacity::kWindowSize) + 1;

  // Window and landmarks.
  FrameState& frame_at(int pos) { return slots_[order_[pos]]; }
  int position_of(int slot) const;
  int find_landmark(std::uint32_t id) const;
  int create_landmark(std::uint32_t id);
  void ingest(const FrameFeatures& ff, int slot);
  void remove_slot(int pos);           // drop a window frame: observations, hosts, order
  void rehost(Landmark& l);
  void compact_landmarks();            // removes landmarks without observations or outliers
  void reset_window(bool keep_newest);
  Eigen::Isometry3d T_w_b(int slot) const;
  bool triangulate_landmark(Landmark& l, int exclude_slot);
  void triangulate_all(int exclude_slot);
  int count_depth_observations(int slot, int* n_2d_with_depth) const;
  float visual_flow_px(int prev_slot, int slot, const Eigen::Vector3d& bg) const;

  // Steps of add_frame.
  void close_interval(FrameState& f);
  bool check_standstill(std::int64_t t_ns, StandstillResult* result);
  void frame_imu_only(FrameState& f);
  void frame_vo(FrameState& f);
  void frame_vio(FrameState& f, EstimatorTiming* timing);
  bool track_pnp(FrameState& f, const Eigen::Isometry3d& prior);
  bool visual_bundle_adjustment(int iterations);
  bool try_alignment(FrameState& f);
  bool static_alignment();
  void set_mode(EstimatorMode to, const char* reason);
  void slide_window(EstimatorTiming* timing);
  void set_nav_from(const FrameState& f);

  // Solver.
  enum Groups : std::uint8_t { k3DGroup = 1, k2DLeftGroup = 2, k2DRightGroup = 4, kAllGroups = 7 };
  struct BuildSpec {
    std::uint8_t groups = kAllGroups;
    bool imu = true;
    bool prior = true;
    bool fix_first_pose = false;
  };
  int build_problem(const BuildSpec& spec);
  int count_candidates(std::uint8_t groups) const;
  bool solve(const BuildSpec& spec, int max_iterations, double max_time_s, bool* converged = nullptr);
  int mark_outliers();
  void save_state(Backup* b) const;
  void restore_state(const Backup& b);
  void rotate_world(const Eigen::Matrix3d& R, const Eigen::Vector3d& pivot);
  bool marginalize_oldest();
  bool marginalize_prior_blocks(int slot);
  bool adopt_marginalization(solver::Problem& problem, const int* ids, int n);
  void update_imu_factors();

  EstimatorOptions options_;
  RigCalibration rig_;
  Eigen::Vector3d g_w_;
  double weight_left_ = 1.0, weight_right_ = 1.0;  // whitening of bearing residuals, 1/rad
  double T_b_c_[2][7];                             // extrinsic pose blocks
  Eigen::Isometry3d T_b_c_iso_[2];

  EstimatorMode mode_ = EstimatorMode::kImuOnly;
  EstimatorStats stats_;
  KeyframeSelector keyframes_;

  std::unique_ptr<FrameState[]> slots_;
  int order_[kSlots] = {};
  int n_ = 0;
  int next_slot_ = 0;
  bool next_pre_started_ = false;

  std::unique_ptr<Landmark[]> landmarks_;           // pool
  std::unique_ptr<std::int16_t[]> free_list_;
  int n_free_ = 0;
  std::unique_ptr<std::uint32_t[]> lm_index_id_;    // sorted by id
  std::unique_ptr<std::int16_t[]> lm_index_;        // pool index, same order
  int n_lm_index_ = 0;

  // IMU
  ImuSample last_imu_;
  bool have_imu_ = false;
  std::unique_ptr<ImuSample[]> recent_;             // ring of the last samples (standstill)
  int recent_head_ = 0, recent_count_ = 0;
  std::unique_ptr<ImuSample[]> scratch_samples_;
  ImuPropagator nav_;
  bool attitude_known_ = false;
  bool velocity_known_ = false;  // at rest once, or estimated by VO/VIO since the start
  StandstillResult last_still_;
  bool last_still_valid_ = false;

  // Solver and residuals.
  std::unique_ptr<solver::Problem> problem_;
  std::unique_ptr<solver::MarginalPrior> prior_;
  std::unique_ptr<solver::MarginalPrior> prior_next_;
  std::uint8_t prior_kind_[solver::capacity::kMaxReducedBlocks] = {};  // 0 pose, 1 speed-bias, 2 extrinsic
  std::int8_t prior_slot_[solver::capacity::kMaxReducedBlocks] = {};   // frame slot (extrinsic: camera)
  std::unique_ptr<BearingResidual[]> visual_;
  std::unique_ptr<RelativePoseCache> pose_cache_;   // frame-to-frame products of visual_
  int n_visual_ = 0;
  std::unique_ptr<int[]> visual_landmark_;          // landmark pool index of each residual
  std::unique_ptr<std::int16_t[]> selected_;        // pool indices of landmarks in the problem
  int n_selected_ = 0;
  std::unique_ptr<int[]> candidates_;
  std::unique_ptr<int[]> block_of_landmark_;
  int pose_id_[kSlots] = {};
  int sb_id_[kSlots] = {};
  int ext_id_[2] = {};
  std::unique_ptr<std::uint8_t[]> block_kind_;      // per BlockId: 0 pose, 1 sb, 2 ext, 3 landmark
  std::unique_ptr<std::int8_t[]> block_slot_;
  SpeedBiasPrior init_prior_;
  int init_prior_slot_ = -1;
  SpeedBiasPrior zero_velocity_;
  StillResidual still_;
  std::unique_ptr<Backup> backup_a_, backup_b_;
  std::unique_ptr<PnpMatch[]> pnp_matches_;
  std::unique_ptr<std::uint8_t[]> pnp_mask_;
  std::unique_ptr<std::int16_t[]> pnp_landmark_;

  int frames_since_align_ = 0;
  Eigen::Vector3d vo_velocity_ = Eigen::Vector3d::Zero();
  EstimatorOutput last_output_;
};

}  // namespace ums
