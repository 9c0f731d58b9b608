#include "core/estimator/problem_builder.hpp"

#include <algorithm>
#include <cmath>

#include "core/estimator/estimator_stats.hpp"
#include "core/estimator/landmark_map.hpp"
#include "core/estimator/marginalizer.hpp"
#include "core/estimator/relative_pose_cache.hpp"
#include "core/estimator/state_blocks.hpp"
#include "core/estimator/visual_edges.hpp"
#include "solver/marginal_prior.hpp"
#include "solver/problem.hpp"

namespace ums {
namespace {
constexpr int kMaxVisualResiduals = static_cast<int>(capacity::kMaxVisualResiduals);
}

ProblemBuilder::ProblemBuilder(const ProblemBuilderOptions& options, Window* window, LandmarkMap* landmarks,
                               Marginalizer* marginalizer, EstimatorStats* stats)
    : options_(options),
      window_(window),
      landmarks_(landmarks),
      marginalizer_(marginalizer),
      stats_(stats),
      problem_(std::make_unique<solver::Problem>()),
      pose_cache_(std::make_unique<RelativePoseCache>()),
      visual_(new BearingResidual[kMaxVisualResiduals]),
      lifts_(new BearingLift[capacity::kMaxLandmarks]),
      chosen_(new int[capacity::kMaxLandmarks]),
      edge_res_(new EdgeResiduals[capacity::kMaxLandmarks]),
      block_of_landmark_(new int[capacity::kMaxLandmarks]),
      relocation_res_(new BearingResidual[capacity::kMaxLoopFeaturesPerKeyframe]),
      relocation_match_(new int[capacity::kMaxLoopFeaturesPerKeyframe]),
      loop_points_(new LoopPointResidual[capacity::kMaxLoopFeaturesPerKeyframe * kLoopPointViews]) {
  static_assert(Window::kSlots <= RelativePoseCache::kMaxFrames, "the pose cache holds every frame slot");
  for (int s = 0; s < Window::kSlots; ++s) pose_cache_->bind_frame(s, window_->slot(s).pose);
  for (int c = 0; c < 2; ++c) pose_cache_->bind_extrinsic(c, window_->extrinsics().block(c));
  problem_->set_evaluation_callback(pose_cache_.get());
  SpeedBiasPrior::Vector9 zero = SpeedBiasPrior::Vector9::Zero();
  SpeedBiasPrior::Vector9 sigma_v = SpeedBiasPrior::Vector9::Zero();
  sigma_v.segment<3>(state::kSbV).setConstant(options_.still_sigma_v);
  zero_velocity_.set(zero, sigma_v);
  still_.set(options_.still_sigma_m, options_.still_sigma_rad);
}

ProblemBuilder::~ProblemBuilder() = default;

void ProblemBuilder::set_init_prior(const SpeedBiasPrior::Vector9& target, const SpeedBiasPrior::Vector9& sigma,
                                    FrameId id) {
  init_prior_.set(target, sigma);
  init_prior_frame_ = id;
  built_current_ = false;
}


void ProblemBuilder::clear_relocation(const SolveSpec& spec) {
  const bool in_problem = n_relocation_ > 0;
  relocation_ = nullptr;
  n_relocation_ = n_loop_points_ = 0;
  if (in_problem)
    build(spec);
  else
    built_current_ = false;
}

bool ProblemBuilder::solve(const SolveSpec& spec, const SolveBudget& budget, bool* converged) {
  build(spec);
  return run_solver(budget, converged);
}

bool ProblemBuilder::solve_again(const SolveSpec& spec, const SolveBudget& budget, bool* converged) {
  if (!(built_current_ && spec == built_spec_)) build(spec);
  return run_solver(budget, converged);
}

bool ProblemBuilder::run_solver(const SolveBudget& budget, bool* converged) {
  solver::SolverOptions opt;
  opt.max_iterations = budget.iterations;
  opt.max_successful_steps = budget.steps;
  opt.max_time_s = budget.time_s;
  opt.function_tolerance = options_.function_tolerance;
  opt.predicted_stop_share = options_.predicted_stop_share;
  opt.reuse_gauss_newton_matrix = options_.reuse_gauss_newton_matrix;
  opt.reuse_factorization = options_.reuse_factorization;
  solver::SolverSummary summary;
  const solver::SolverStatus st = problem_->solve(opt, &summary);
  count_solve(summary);
  window_->extrinsics().sync();  // the solver may have moved them (estimate_extrinsic)
  if (converged != nullptr) {
    *converged = st == solver::SolverStatus::kConverged ||
                 (st == solver::SolverStatus::kMaxIterations &&
                  summary.termination == solver::Termination::kMaxSuccessfulSteps);
  }
  return solver::usable(st);
}

void ProblemBuilder::count_solve(const solver::SolverSummary& summary) {
  auto add = [](std::uint64_t* total, int n) { *total += static_cast<std::uint64_t>(std::max(n, 0)); };
  ++stats_->solves;
  add(&stats_->solver_iterations, summary.iterations);
  add(&stats_->solver_successful_steps, summary.successful_steps);
  add(&stats_->solver_linearizations, summary.linearizations);
  add(&stats_->solver_gradient_passes, summary.gradient_passes);
  add(&stats_->solver_factor_reuses, summary.factor_reuses);
  add(&stats_->solver_residual_passes, summary.residual_passes);
}

int ProblemBuilder::build(const SolveSpec& spec) {
  ++stats_->problem_builds;
  built_spec_ = spec;
  outliers_kept_ = false;
  built_current_ = true;
  problem_->clear();
  n_visual_ = 0;
  n_chosen_ = n_selected_;
  n_selected_ = 0;
  n_selected_group_[0] = n_selected_group_[1] = n_selected_group_[2] = 0;
  add_state_blocks(spec);
  add_landmarks(spec.groups);
  if (relocation_ != nullptr && spec.imu) add_relocation_terms();
  stats_->peak_residuals = std::max(stats_->peak_residuals, static_cast<std::size_t>(n_visual_));
  if (spec.imu) add_imu_terms();
  if (extrinsics_float(spec)) add_extrinsic_priors();
  if (options_.estimate_td && spec.imu) {
    td_prior_.set(window_->time_offset().calibration_s(), options_.td_sigma_s);
    problem_->add_residual(&td_prior_, solver::RobustLoss::trivial(), {td_id_});
  }
  if (options_.estimate_gyro_scale && spec.imu) {
    gyro_scale_prior_.set(Eigen::Vector3d::Zero(), options_.gyro_scale_sigma);
    problem_->add_residual(&gyro_scale_prior_, solver::RobustLoss::trivial(), {gs_id_});
  }
  if (spec.prior && !marginalizer_->empty()) add_marginal_prior();
  // After a keyframe the oldest frame and its landmarks are marginalized from this problem
  // (Estimator::slide_window): the solve keeps their terms for it.
  if (spec.imu && !window_->empty() && window_->newest().keyframe) {
    int ids[2 + capacity::kMaxLandmarks];
    problem_->set_marginalization_hint(ids, oldest_frame_blocks(ids));
  }
  return n_selected_;
}

void ProblemBuilder::add_state_blocks(const SolveSpec& spec) {
  solver::Problem& P = *problem_;
  Window& w = *window_;
  for (int k = 0; k < w.size(); ++k) {
    const int s = w.slot_at(k);
    WindowFrame& f = w.slot(s);
    P.add_pose_block(f.pose, &pose_id_[s]);
    table_.note(pose_id_[s], BlockKind::kPose, f.id);
    P.add_euclidean_block(f.sb, state::kSbSize, &sb_id_[s]);
    table_.note(sb_id_[s], BlockKind::kSpeedBias, f.id);
    if (!spec.imu) P.set_constant(sb_id_[s], true);
  }
  for (int c = 0; c < 2; ++c) {
    P.add_pose_block(w.extrinsics().block(c), &ext_id_[c]);
    table_.note(ext_id_[c], BlockKind::kExtrinsic, static_cast<std::uint32_t>(c));
    P.set_constant(ext_id_[c], !extrinsics_float(spec));
  }
  if (options_.estimate_td) {
    P.add_euclidean_block(w.time_offset().block(), 1, &td_id_);
    table_.note(td_id_, BlockKind::kTimeOffset, 0);
    P.set_constant(td_id_, !spec.imu);
  }
  if (options_.estimate_gyro_scale) {
    P.add_euclidean_block(w.gyro_scale().block(), 3, &gs_id_);
    table_.note(gs_id_, BlockKind::kGyroScale, 0);
    P.set_constant(gs_id_, !spec.imu);
  }
  if (spec.fix_first_pose && w.size() > 0) P.set_constant(pose_id_[w.slot_at(0)], true);
}

void ProblemBuilder::refresh_edge_time_offset() {
  edge_td_.on = options_.estimate_td;
  for (int k = 0; k < window_->size(); ++k) {
    const int s = window_->slot_at(k);
    edge_td_.td_applied_s[s] = window_->slot(s).td_applied_s;
  }
}

void ProblemBuilder::add_landmarks(std::uint8_t groups) {
  refresh_edge_time_offset();
  // A relocation looks its landmarks up by pool index: those not chosen must read as absent.
  if (relocation_ != nullptr) std::fill(block_of_landmark_.get(), block_of_landmark_.get() + capacity::kMaxLandmarks, -1);
  const int keep = reuse_selection_ ? kept_selection() : select_landmarks(*landmarks_, groups, options_.selection, chosen_.get());
  for (int c = 0; c < keep; ++c) {
    const int idx = chosen_[c];
    Landmark& l = landmarks_->at_pool(idx);
    if (n_visual_ + count_rays(l) > kMaxVisualResiduals) {
      ++stats_->drops_residuals;
      break;
    }
    int lm_id = -1;
    problem_->add_landmark_block(&l.inv_depth, 1, &lm_id);
    table_.note(lm_id, BlockKind::kLandmark, l.id);
    block_of_landmark_[idx] = lm_id;
    EdgeResiduals& er = edge_res_[n_selected_];
    ++n_selected_;
    ++n_selected_group_[static_cast<int>(l.group())];
    er.begin = problem_->num_residuals();
    er.whole = add_landmark_edges(idx, lm_id);
    er.end = problem_->num_residuals();
    set_lift(l, lm_id, n_selected_ - 1);
  }
}

// The landmark's residuals see its host pose and inverse depth through its world point
// (bearing_lift.hpp); with a time offset the host bearing moves with td: no lift then.
void ProblemBuilder::set_lift(const Landmark& l, int lm_block, int k) {
  if (edge_td_.on) return;
  lifts_[k].set(l.b_host);
  const solver::BlockId ext = ext_id_[l.host_cam];
  problem_->set_point_lift(&lifts_[k], pose_id_[l.host_slot], lm_block, &ext, 1);
}

int ProblemBuilder::block_id(const EdgeBlock& b, int lm_block) const {
  switch (b.kind) {
    case EdgeBlock::kPose: return pose_id_[b.index];
    case EdgeBlock::kExtrinsic: return ext_id_[b.index];
    case EdgeBlock::kTimeOffset: return td_id_;
    case EdgeBlock::kInverseDepth: break;
  }
  return lm_block;
}

bool ProblemBuilder::add_landmark_edges(int pool_idx, int lm_block) {
  const Landmark& l = landmarks_->at_pool(pool_idx);
  const solver::RobustLoss huber = solver::RobustLoss::huber(options_.huber_rad);
  const double w = edge_weight(l);
  bool whole = true;
  for_each_visual_edge(l, [&](const VisualEdge& e) {
    BearingResidual& r = visual_[n_visual_];
    EdgeBlock blocks[kMaxEdgeBlocks];
    const int nb = setup_visual_edge(l, e, w, pose_cache_.get(), &r, blocks, edge_td_);
    solver::BlockId ids[kMaxEdgeBlocks];
    for (int i = 0; i < nb; ++i) ids[i] = block_id(blocks[i], lm_block);
    if (problem_->add_residual(&r, huber, ids, nb) != solver::SolverStatus::kOk) {
      ++stats_->drops_residuals;
      whole = false;
      return true;
    }
    ++n_visual_;
    return true;
  });
  return whole;
}

void ProblemBuilder::add_imu_terms() {
  solver::Problem& P = *problem_;
  Window& w = *window_;
  for (int k = 1; k < w.size(); ++k) {
    const int si = w.slot_at(k - 1), sj = w.slot_at(k);
    if (!w.slot(sj).imu_ok) continue;
    ImuFactor* imu = &w.slot(sj).imu;
    imu->set_gyro_scale(options_.estimate_gyro_scale);
    if (options_.estimate_gyro_scale) {
      P.add_residual(imu, solver::RobustLoss::trivial(), {pose_id_[si], sb_id_[si], pose_id_[sj], sb_id_[sj], gs_id_});
    } else {
      P.add_residual(imu, solver::RobustLoss::trivial(), {pose_id_[si], sb_id_[si], pose_id_[sj], sb_id_[sj]});
    }
  }
  const int prior_slot = init_prior_frame_ == kNoFrame ? -1 : w.slot_of_id(init_prior_frame_);
  if (prior_slot >= 0) P.add_residual(&init_prior_, solver::RobustLoss::trivial(), {sb_id_[prior_slot]});
  for (int k = 0; k < w.size(); ++k) {
    const int s = w.slot_at(k);
    if (!w.slot(s).still) continue;
    P.add_residual(&zero_velocity_, solver::RobustLoss::trivial(), {sb_id_[s]});
    if (k > 0 && w.at(k - 1).still)
      P.add_residual(&still_, solver::RobustLoss::trivial(), {pose_id_[w.slot_at(k - 1)], pose_id_[s]});
  }
}

void ProblemBuilder::add_extrinsic_priors() {
  const Extrinsics& e = window_->extrinsics();
  for (int c = 0; c < 2; ++c) {
    const Eigen::Isometry3d& T = e.calibration(c);
    extrinsic_prior_[c].set(T.translation(), Eigen::Quaterniond(T.linear()), options_.extrinsic_sigma_m,
                            options_.extrinsic_sigma_rad);
    problem_->add_residual(&extrinsic_prior_[c], solver::RobustLoss::trivial(), {ext_id_[c]});
  }
  const Eigen::Isometry3d T_c0_c1 = e.calibration(0).inverse() * e.calibration(1);
  baseline_prior_.set(T_c0_c1.translation(), Eigen::Quaterniond(T_c0_c1.linear()), options_.baseline_sigma_m,
                      options_.baseline_sigma_rad);
  problem_->add_residual(&baseline_prior_, solver::RobustLoss::trivial(), {ext_id_[0], ext_id_[1]});
}

void ProblemBuilder::add_marginal_prior() {
  solver::BlockId ids[solver::capacity::kMaxReducedBlocks];
  bool ok = true;
  for (int i = 0; i < marginalizer_->num_blocks() && ok; ++i) {
    const BlockName& nm = marginalizer_->name(i);
    if (nm.kind == BlockKind::kExtrinsic) {
      ids[i] = ext_id_[nm.owner];
      continue;
    }
    if (nm.kind == BlockKind::kTimeOffset) {
      ids[i] = td_id_;
      ok = td_id_ >= 0;
      continue;
    }
    if (nm.kind == BlockKind::kGyroScale) {
      ids[i] = gs_id_;
      ok = gs_id_ >= 0;
      continue;
    }
    const int s = window_->slot_of_id(nm.owner);
    ok = s >= 0;
    ids[i] = !ok ? -1 : nm.kind == BlockKind::kPose ? pose_id_[s] : sb_id_[s];
  }
  if (ok) {
    problem_->add_prior(marginalizer_->prior(), ids);
  } else {
    marginalizer_->clear();  // a frame of the prior left without marginalization: cannot happen
    ++stats_->marginalization_failures;
  }
}

void ProblemBuilder::set_relocation(const RelocationRequest* request, const Eigen::Isometry3d& T_odom_loop) {
  built_current_ = false;
  relocation_ = request;
  n_relocation_ = 0;
  pose_from_iso(T_odom_loop, relocation_pose_);
}

Eigen::Isometry3d ProblemBuilder::relocation_pose() const { return iso_from_pose(relocation_pose_); }

int ProblemBuilder::relocation_candidates(int* match_of) const {
  int n = 0;
  for (std::size_t m = 0; m < relocation_->matches.size(); ++m) {
    const int idx = landmarks_->find(relocation_->matches[m].landmark_id);
    if (idx < 0 || block_of_landmark_[idx] < 0) continue;
    const Landmark& l = landmarks_->at_pool(idx);
    if (l.outlier || !l.has_depth) continue;
    match_of[n++] = static_cast<int>(m);
  }
  return n;
}

void ProblemBuilder::add_relocation_terms() {
  n_loop_points_ = 0;
  n_relocation_ = relocation_candidates(relocation_match_.get());
  if (n_relocation_ < options_.min_relocation_residuals) {
    n_relocation_ = 0;
    return;
  }
  problem_->add_pose_block(relocation_pose_, &relocation_id_);
  table_.note(relocation_id_, BlockKind::kRelocation, relocation_->loop);
  const solver::RobustLoss huber = solver::RobustLoss::huber(options_.huber_rad);
  int added = 0;
  for (int k = 0; k < n_relocation_; ++k) {
    const RelocationMatch& m = relocation_->matches[static_cast<std::size_t>(relocation_match_[k])];
    const int idx = landmarks_->find(m.landmark_id);
    const Landmark& l = landmarks_->at_pool(idx);
    // The loop keyframe's left camera sees the landmark: host -> (loop pose, cam0).
    BearingResidual& r = relocation_res_[added];
    const bool same_camera = l.host_cam == 0;
    r.set(BearingResidual::Kind::kTwoFrames, same_camera, l.b_host, m.bearing_c0.cast<double>(), options_.weight_3d);
    const solver::BlockId lm = block_of_landmark_[idx];
    const solver::BlockId host = pose_id_[l.host_slot];
    const solver::SolverStatus st =
        same_camera ? problem_->add_residual(&r, huber, {host, relocation_id_, ext_id_[0], lm})
                    : problem_->add_residual(&r, huber, {host, relocation_id_, ext_id_[l.host_cam], ext_id_[0], lm});
    if (st != solver::SolverStatus::kOk) {
      ++stats_->drops_residuals;
      break;
    }
    relocation_match_[added++] = relocation_match_[k];
    add_loop_point_views(l, m);
  }
  n_relocation_ = added;
}

void ProblemBuilder::add_loop_point_views(const Landmark& l, const RelocationMatch& m) {
  const solver::RobustLoss loss = solver::RobustLoss::huber(options_.huber_rad);
  const Eigen::Vector3d p_c0 = iso_from_pose(window_->extrinsics().block(0)).inverse() * m.p_loop_b.cast<double>();
  if (!(p_c0.z() > options_.min_depth_m)) return;
  // The first, a middle and the last left observation: the window's span, not ten near-copies.
  int left[capacity::kMaxObservationsPerLandmark];
  int n = 0;
  for (int k = 0; k < l.n_obs; ++k)
    if (l.obs[k].has_left) left[n++] = k;
  const int picks[kLoopPointViews] = {0, n / 2, n - 1};
  for (int i = 0; i < kLoopPointViews && n > 0; ++i) {
    if (i > 0 && picks[i] == picks[i - 1]) continue;
    const LandmarkObservation& o = l.obs[left[picks[i]]];
    LoopPointResidual& r = loop_points_[n_loop_points_];
    r.set(p_c0, o.bearing_left.cast<double>(), options_.weight_3d);
    if (problem_->add_residual(&r, loss, {relocation_id_, pose_id_[o.slot], ext_id_[0]}) != solver::SolverStatus::kOk) {
      ++stats_->drops_residuals;
      return;
    }
    ++n_loop_points_;
  }
}

int ProblemBuilder::relocation_inliers() {
  if (relocation_ == nullptr) return 0;
  pose_cache_->invalidate();
  int inliers = 0;
  for (int k = 0; k < n_relocation_; ++k) {
    const RelocationMatch& m = relocation_->matches[static_cast<std::size_t>(relocation_match_[k])];
    const int idx = landmarks_->find(m.landmark_id);
    if (idx < 0) continue;  // removed as an outlier of the window since
    Landmark& l = landmarks_->at_pool(idx);
    const double* params[5];
    int nb = 0;
    params[nb++] = window_->slot(l.host_slot).pose;
    params[nb++] = relocation_pose_;
    if (l.host_cam != 0) params[nb++] = window_->extrinsics().block(l.host_cam);
    params[nb++] = window_->extrinsics().block(0);
    params[nb++] = &l.inv_depth;
    double err = 0.0;
    if (relocation_res_[k].error_rad(params, &err) && err <= options_.outlier_rad) ++inliers;
  }
  return inliers;
}

void ProblemBuilder::note_window_moved(const Eigen::Matrix3d& R) {
  int ids[capacity::kWindowSize + 2];
  int n = 0;
  for (int k = 0; k < window_->size(); ++k) ids[n++] = pose_id_[window_->slot_at(k)];
  // The loop keyframe's pose is a world pose the move left where it was: listed, it fails the
  // rigidity check and the marginalization linearizes afresh (clear_relocation rebuilds anyway).
  if (n_relocation_ > 0) ids[n++] = relocation_id_;
  problem_->note_world_moved(ids, n, R);
}

int ProblemBuilder::oldest_frame_blocks(int* ids, int* outliers) const {
  const int s0 = window_->slot_at(0);
  int n = 0, marked = 0;
  ids[n++] = pose_id_[s0];
  ids[n++] = sb_id_[s0];
  for (int i = 0; i < n_selected_; ++i) {
    const Landmark& l = landmarks_->at_pool(chosen_[i]);
    if (l.find_obs(s0) < 0) continue;
    ids[n++] = block_of_landmark_[chosen_[i]];
    marked += l.outlier ? 1 : 0;
  }
  if (outliers != nullptr) *outliers = marked;
  return n;
}

int ProblemBuilder::mark_outliers() {
  // A landmark with any observation farther than outlier_rad from its prediction is dropped (it
  // leaves the map; the front end keeps tracking it and it comes back as a new landmark). Right
  // after the solve its residuals at the solution are known; otherwise they are evaluated.
  pose_cache_->invalidate();  // evaluated outside a solve: the window may have moved since
  refresh_edge_time_offset();
  const bool solved = problem_->solved_residuals_current();
  int marked = 0;
  for (int i = 0; i < n_selected_; ++i) {
    Landmark& l = landmarks_->at_pool(chosen_[i]);
    if (!(l.inv_depth > 1.0 / options_.max_depth_m && l.inv_depth < 1.0 / options_.min_depth_m)) {
      l.has_depth = false;  // re-triangulated later
      built_current_ = false;
      continue;
    }
    int verdict = solved && edge_res_[i].whole ? solved_edges_outlier(edge_res_[i], edge_weight(l)) : -1;
    if (verdict < 0) verdict = evaluated_edges_outlier(l) ? 1 : 0;
    if (verdict == 1) {
      l.outlier = true;
      ++marked;
    }
  }
  stats_->outlier_landmarks += static_cast<std::uint64_t>(marked);
  if (marked > 0) built_current_ = false;  // the selection changes (landmarks_->compact())
  return marked;
}

bool ProblemBuilder::rebuild_without_kept_outliers() {
  if (!outliers_kept_) return false;
  reuse_selection_ = true;
  build(built_spec_);
  reuse_selection_ = false;
  return true;
}

// The last build's landmarks without the marked ones, in their order: the round 1 they were
// solved in, not candidates that took their places (their depths were solved by no one).
int ProblemBuilder::kept_selection() {
  int keep = 0;
  for (int i = 0; i < n_chosen_; ++i)
    if (!landmarks_->at_pool(chosen_[i]).outlier) chosen_[keep++] = chosen_[i];
  return keep;
}

// 1: an edge's residual at the solution is beyond outlier_rad (the residual is whitened by w);
// 0: none is; -1: undecided here, the edges must be evaluated: a residual was not kept, or an
// error lies within rounding of the threshold (|r| / w need not round as the unwhitened error
// does, and the verdict must not depend on it).
int ProblemBuilder::solved_edges_outlier(const EdgeResiduals& er, double w) const {
  const double band = 1e-9 * options_.outlier_rad;
  for (int k = er.begin; k < er.end; ++k) {
    const double* r = problem_->solved_residual(k);
    if (r == nullptr) return -1;
    const double err = std::sqrt(r[0] * r[0] + r[1] * r[1]) / w;
    if (std::abs(err - options_.outlier_rad) <= band) return -1;
    if (err > options_.outlier_rad) return 1;
  }
  return 0;
}

bool ProblemBuilder::evaluated_edges_outlier(const Landmark& l) {
  bool bad = false;
  for_each_visual_edge(l, [&](const VisualEdge& e) {
    BearingResidual r;
    EdgeBlock blocks[kMaxEdgeBlocks];
    const int nb = setup_visual_edge(l, e, 1.0, pose_cache_.get(), &r, blocks, edge_td_);
    const double* params[kMaxEdgeBlocks];
    for (int b = 0; b < nb; ++b) {
      const EdgeBlock& eb = blocks[b];
      params[b] = eb.kind == EdgeBlock::kPose         ? window_->slot(eb.index).pose
                  : eb.kind == EdgeBlock::kExtrinsic  ? window_->extrinsics().block(eb.index)
                  : eb.kind == EdgeBlock::kTimeOffset ? window_->time_offset().block()
                                                      : &l.inv_depth;
    }
    double err = 0.0;
    bad = !r.error_rad(params, &err) || err > options_.outlier_rad;
    return !bad;
  });
  return bad;
}

}  // namespace ums
