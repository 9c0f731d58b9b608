#pragma once
// The only place that turns the window into a solver problem (paper eq. 4): state blocks, the
// chosen landmarks' bearing residuals (visual_edges.hpp), IMU factors, the initialization bias
// prior, the still constraints and the marginalization prior; then the solve, and the outlier
// check over the same edges. Owns the solver Problem, the residual objects, the relative pose
// cache and the block table: every byte allocated in the constructor.

#include <cstdint>
#include <memory>

#include "core/estimator/bearing_lift.hpp"
#include "core/estimator/bearing_residual.hpp"
#include "core/estimator/block_table.hpp"
#include "core/estimator/frame_id.hpp"
#include "core/estimator/landmark_selection.hpp"
#include "core/estimator/loop_point_residual.hpp"
#include "core/estimator/relocation.hpp"
#include "core/estimator/state_residuals.hpp"
#include "core/estimator/visual_edges.hpp"
#include "core/estimator/window.hpp"

namespace ums {
namespace solver {
class Problem;
struct SolverSummary;
}

class LandmarkMap;
class Marginalizer;
class RelativePoseCache;
struct EstimatorStats;

struct ProblemBuilderOptions {
  double weight_3d = 1.0;  // 1/rad, whitening of a 3D (stereo) landmark's bearing residuals
  double weight_2d = 1.0;  // 1/rad, of a 2D (one-camera) landmark's
  double huber_rad = 1.0;     // Huber threshold in whitened units (huber_px / sigma_px)
  double outlier_rad = 0.0;   // rad, observation error that marks an outlier (outlier_px / focal)
  double min_depth_m = 0.1;
  double max_depth_m = 60.0;
  bool estimate_extrinsic = false;
  double extrinsic_sigma_m = 0.05, extrinsic_sigma_rad = 0.05;   // prior around the calibration
  double baseline_sigma_m = 0.0005, baseline_sigma_rad = 0.001;  // the stereo pair's relative pose
  bool estimate_td = false;  // the time offset floats in the VIO solves (time_offset.hpp)
  double td_sigma_s = 0.05;  // s, prior around the calibration's td
  bool estimate_gyro_scale = false;  // the gyro's scale-factor error floats in the VIO solves
  double gyro_scale_sigma = 0.01;    // prior around zero (1 %)
  double function_tolerance = 1e-3;
  double predicted_stop_share = 0.5;
  bool reuse_gauss_newton_matrix = true;  // SolverOptions::reuse_gauss_newton_matrix
  bool reuse_factorization = true;        // SolverOptions::reuse_factorization
  SelectionPolicy selection;
  double still_sigma_m = 0.002, still_sigma_rad = 0.001, still_sigma_v = 0.01;
  // Fewer of a relocation's landmarks in the solve than this and the loop keyframe's pose is
  // left out (6 unknowns: a handful of rays would only fit their own noise).
  int min_relocation_residuals = 12;
};

// How far one solve may go: LM step attempts, accepted steps (0: no limit; the solve then ends
// without linearizing at the last one, solver::SolverOptions::max_successful_steps) and wall time.
struct SolveBudget {
  int iterations = 50;  // count
  int steps = 0;        // count
  double time_s = 1e9;  // s
};

// What one solve contains.
struct SolveSpec {
  std::uint8_t groups = kAllGroups;  // landmark classes
  bool imu = true;                   // IMU factors, bias prior, still constraints; else speed-bias fixed
  bool prior = true;                 // the marginalization prior
  bool fix_first_pose = false;       // vision only: the gauge

  bool operator==(const SolveSpec& o) const {
    return groups == o.groups && imu == o.imu && prior == o.prior && fix_first_pose == o.fix_first_pose;
  }
};

class ProblemBuilder {
 public:
  ProblemBuilder(const ProblemBuilderOptions& options, Window* window, LandmarkMap* landmarks,
                 Marginalizer* marginalizer, EstimatorStats* stats);
  ~ProblemBuilder();
  ProblemBuilder(const ProblemBuilder&) = delete;
  ProblemBuilder& operator=(const ProblemBuilder&) = delete;

  // Builds and solves; false when the solver's result is not usable. *converged: a tolerance
  // ended the solve, or the budget's accepted steps (by design, not cut short).
  bool solve(const SolveSpec& spec, const SolveBudget& budget, bool* converged = nullptr);
  // The second round (Estimator::second_round): as solve(), but when the outlier check since the
  // last solve marked nothing and dropped no depth, the builder has changed nothing since, and
  // spec is the last solve's, the last solve's problem is solved again from the values it
  // returned instead of being built anew: the build would give the same problem (its blocks,
  // residuals and their order depend on the landmarks' and frames' flags and measurements, not
  // on the values a solve moves). The caller must not have changed the window or the landmarks
  // in between.
  bool solve_again(const SolveSpec& spec, const SolveBudget& budget, bool* converged = nullptr);
  // The outliers just marked stay in the map, and in the last problem, until the end of the
  // frame (no second round: Estimator::second_round); forget_kept_outliers() when they are
  // released, a build leaves them out.
  void keep_outliers() { outliers_kept_ = true; }
  void forget_kept_outliers() { outliers_kept_ = false; }
  // With kept outliers: the last problem is built again with its landmarks but them (no others
  // in their places), not solved (a marginalization then linearizes its terms itself). True when
  // it was. For a marginalization that would take a kept outlier into the prior
  // (oldest_frame_blocks counts them).
  bool rebuild_without_kept_outliers();
  // Marks the landmarks of the last solve with an observation beyond outlier_rad (or a depth out
  // of range: depth dropped, re-triangulated later); returns how many were marked.
  int mark_outliers();

  // The bias prior of the initialization, on the speed-bias of frame `id` while it is in the window.
  void set_init_prior(const SpeedBiasPrior::Vector9& target, const SpeedBiasPrior::Vector9& sigma, FrameId id);
  void clear_init_prior() {
    init_prior_frame_ = kNoFrame;
    built_current_ = false;
  }
  // With estimate_extrinsic, the extrinsics float (under their priors) in the VIO solves from
  // this call on; before, they are held at the calibration.
  void release_extrinsics() {
    extrinsics_released_ = true;
    built_current_ = false;
  }
  void hold_extrinsics() {
    extrinsics_released_ = false;
    built_current_ = false;
  }
  bool extrinsics_released() const { return extrinsics_released_; }

  // Tightly coupled relocation (relocation.hpp): until clear_relocation(), every VIO solve adds
  // the loop keyframe's pose, started at T_odom_loop, and the bearing residuals of the request's
  // landmarks that are in the solve. request: not owned, outlives the relocation.
  void set_relocation(const RelocationRequest* request, const Eigen::Isometry3d& T_odom_loop);
  // Ends it and builds the last solve's problem again without it (not solved): the marginalizer
  // takes that problem, and the loop keyframe must not enter the prior.
  void clear_relocation(const SolveSpec& spec);
  Eigen::Isometry3d relocation_pose() const;  // T_odom_loop after the last solve
  int relocation_residuals() const { return n_relocation_; }  // landmark -> loop keyframe
  int loop_point_residuals() const { return n_loop_points_; }  // loop keyframe's point -> window
  // Of those, within outlier_rad at the current states.
  int relocation_inliers();

  // The last problem, for the marginalizer: the oldest frame's blocks and the landmarks it hosts.
  solver::Problem& problem() { return *problem_; }
  BlockTable& blocks() { return table_; }
  // *outliers (optional): of its landmarks, those marked as outliers (keep_outliers()).
  int oldest_frame_blocks(int* ids, int* outliers = nullptr) const;
  bool relocating() const { return relocation_ != nullptr; }
  // The window's poses were moved together by a rotation R of the world frame (and a translation)
  // since the last solve (Estimator::hold_gauge): the terms the problem keeps for the
  // marginalization follow (solver::Problem::note_world_moved).
  void note_window_moved(const Eigen::Matrix3d& R);
  int num_selected() const { return n_selected_; }
  // Of those, in one feature class: counted when chosen, because a landmark of the last solve may
  // be released before the frame's output is written (outliers, a failed alignment's restore).
  int num_selected(LandmarkGroup group) const { return n_selected_group_[static_cast<int>(group)]; }

 private:
  int build(const SolveSpec& spec);
  bool run_solver(const SolveBudget& budget, bool* converged);  // solves the problem built
  void count_solve(const solver::SolverSummary& summary);  // into stats_
  void add_state_blocks(const SolveSpec& spec);
  void add_landmarks(std::uint8_t groups);
  // False when an edge did not fit in the problem.
  bool add_landmark_edges(int pool_idx, int lm_block);
  double edge_weight(const Landmark& l) const { return l.stereo ? options_.weight_3d : options_.weight_2d; }
  // A chosen landmark's residuals in the problem: ids begin .. end-1, one per visual edge in
  // for_each_visual_edge's order when whole.
  struct EdgeResiduals {
    int begin = 0, end = 0;
    bool whole = false;
  };
  int solved_edges_outlier(const EdgeResiduals& er, double w) const;
  bool evaluated_edges_outlier(const Landmark& l);
  void add_imu_terms();
  void add_extrinsic_priors();
  bool extrinsics_float(const SolveSpec& spec) const {
    return options_.estimate_extrinsic && extrinsics_released_ && spec.imu;
  }
  void refresh_edge_time_offset();  // edge_td_ from the window's frames
  void add_marginal_prior();
  void add_relocation_terms();
  // The request's matches whose landmarks qualify (see set_relocation), as match indices.
  int relocation_candidates(int* match_of) const;
  int block_id(const EdgeBlock& b, int lm_block) const;
  void set_lift(const Landmark& l, int lm_block, int k);
  int kept_selection();

  ProblemBuilderOptions options_;
  Window* window_;
  LandmarkMap* landmarks_;
  Marginalizer* marginalizer_;
  EstimatorStats* stats_;
  std::unique_ptr<solver::Problem> problem_;
  std::unique_ptr<RelativePoseCache> pose_cache_;
  std::unique_ptr<BearingResidual[]> visual_;
  int n_visual_ = 0;
  std::unique_ptr<BearingLift[]> lifts_;  // by position in chosen_
  std::unique_ptr<int[]> chosen_;              // pool indices of the landmarks in the problem
  std::unique_ptr<EdgeResiduals[]> edge_res_;  // by position in chosen_
  std::unique_ptr<int[]> block_of_landmark_;   // by pool index
  int n_selected_ = 0;
  int n_selected_group_[3] = {0, 0, 0};
  BlockTable table_;
  int pose_id_[Window::kSlots] = {};
  int sb_id_[Window::kSlots] = {};
  int ext_id_[2] = {};
  int td_id_ = -1;  // with estimate_td
  EdgeTimeOffset edge_td_;
  int gs_id_ = -1;  // with estimate_gyro_scale
  SpeedBiasPrior init_prior_;
  FrameId init_prior_frame_ = kNoFrame;
  SpeedBiasPrior zero_velocity_;
  StillResidual still_;
  bool extrinsics_released_ = false;
  // The problem built last (with built_spec_) is what a build would give now, as far as the
  // builder knows: nothing it holds changed since and the outlier check changed no landmark.
  bool built_current_ = false;
  bool outliers_kept_ = false;  // keep_outliers(): marked landmarks of the last problem still in the map
  bool reuse_selection_ = false;  // the next build takes kept_selection(), not a new selection
  int n_chosen_ = 0;              // chosen_'s length at the last build's start (kept_selection)
  SolveSpec built_spec_;
  PosePrior extrinsic_prior_[2];
  RelativePosePrior baseline_prior_;
  ScalarPrior td_prior_;
  Vector3Prior gyro_scale_prior_;
  const RelocationRequest* relocation_ = nullptr;
  double relocation_pose_[state::kPoseSize] = {};
  std::unique_ptr<BearingResidual[]> relocation_res_;
  std::unique_ptr<int[]> relocation_match_;  // per relocation residual: its match index
  int n_relocation_ = 0;
  static constexpr int kLoopPointViews = 3;   // window frames that see a loop keyframe's point
  std::unique_ptr<LoopPointResidual[]> loop_points_;
  int n_loop_points_ = 0;
  void add_loop_point_views(const Landmark& l, const RelocationMatch& m);
  int relocation_id_ = -1;
};

}  // namespace ums
