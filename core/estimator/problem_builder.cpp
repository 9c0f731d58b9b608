#include "core/estimator/problem_builder.hpp"

#include <algorithm>

#include "core/estimator/estimator_stats.hpp"
#include "core/estimator/landmark_map.hpp"
#include "core/estimator/marginalizer.hpp"
#include "core/estimator/relative_pose_cache.hpp"
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
      chosen_(new int[capacity::kMaxLandmarks]),
      block_of_landmark_(new int[capacity::kMaxLandmarks]) {
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
}


bool ProblemBuilder::solve(const SolveSpec& spec, int max_iterations, double max_time_s, bool* converged) {
  build(spec);
  solver::SolverOptions opt;
  opt.max_iterations = max_iterations;
  opt.max_time_s = max_time_s;
  opt.function_tolerance = options_.function_tolerance;
  solver::SolverSummary summary;
  const solver::SolverStatus st = problem_->solve(opt, &summary);
  ++stats_->solves;
  window_->extrinsics().sync();  // the solver may have moved them (estimate_extrinsic)
  if (converged != nullptr) *converged = st == solver::SolverStatus::kConverged;
  return solver::usable(st);
}

int ProblemBuilder::build(const SolveSpec& spec) {
  problem_->clear();
  n_visual_ = 0;
  n_selected_ = 0;
  n_selected_group_[0] = n_selected_group_[1] = n_selected_group_[2] = 0;
  add_state_blocks(spec);
  add_landmarks(spec.groups);
  stats_->peak_residuals = std::max(stats_->peak_residuals, static_cast<std::size_t>(n_visual_));
  if (spec.imu) add_imu_terms();
  if (spec.prior && !marginalizer_->empty()) add_marginal_prior();
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
    P.set_constant(ext_id_[c], !options_.estimate_extrinsic);
  }
  if (spec.fix_first_pose && w.size() > 0) P.set_constant(pose_id_[w.slot_at(0)], true);
}

void ProblemBuilder::add_landmarks(std::uint8_t groups) {
  const int keep = select_landmarks(*landmarks_, groups, options_.selection, chosen_.get());
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
    ++n_selected_;
    ++n_selected_group_[static_cast<int>(l.group())];
    add_landmark_edges(idx, lm_id);
  }
}

int ProblemBuilder::block_id(const EdgeBlock& b, int lm_block) const {
  switch (b.kind) {
    case EdgeBlock::kPose: return pose_id_[b.index];
    case EdgeBlock::kExtrinsic: return ext_id_[b.index];
    case EdgeBlock::kInverseDepth: break;
  }
  return lm_block;
}

bool ProblemBuilder::add_landmark_edges(int pool_idx, int lm_block) {
  const Landmark& l = landmarks_->at_pool(pool_idx);
  const solver::RobustLoss huber = solver::RobustLoss::huber(options_.huber_rad);
  const double w = l.stereo ? options_.weight_3d : options_.weight_2d;
  for_each_visual_edge(l, [&](const VisualEdge& e) {
    BearingResidual& r = visual_[n_visual_];
    EdgeBlock blocks[5];
    const int nb = setup_visual_edge(l, e, w, pose_cache_.get(), &r, blocks);
    solver::BlockId ids[5];
    for (int i = 0; i < nb; ++i) ids[i] = block_id(blocks[i], lm_block);
    if (problem_->add_residual(&r, huber, ids, nb) != solver::SolverStatus::kOk) {
      ++stats_->drops_residuals;
      return true;
    }
    ++n_visual_;
    return true;
  });
  return true;
}

void ProblemBuilder::add_imu_terms() {
  solver::Problem& P = *problem_;
  Window& w = *window_;
  for (int k = 1; k < w.size(); ++k) {
    const int si = w.slot_at(k - 1), sj = w.slot_at(k);
    if (!w.slot(sj).imu_ok) continue;
    P.add_residual(&w.slot(sj).imu, solver::RobustLoss::trivial(), {pose_id_[si], sb_id_[si], pose_id_[sj], sb_id_[sj]});
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

void ProblemBuilder::add_marginal_prior() {
  solver::BlockId ids[solver::capacity::kMaxReducedBlocks];
  bool ok = true;
  for (int i = 0; i < marginalizer_->num_blocks() && ok; ++i) {
    const BlockName& nm = marginalizer_->name(i);
    if (nm.kind == BlockKind::kExtrinsic) {
      ids[i] = ext_id_[nm.owner];
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

int ProblemBuilder::oldest_frame_blocks(int* ids) const {
  const int s0 = window_->slot_at(0);
  int n = 0;
  ids[n++] = pose_id_[s0];
  ids[n++] = sb_id_[s0];
  for (int i = 0; i < n_selected_; ++i)
    if (landmarks_->at_pool(chosen_[i]).find_obs(s0) >= 0) ids[n++] = block_of_landmark_[chosen_[i]];
  return n;
}

int ProblemBuilder::mark_outliers() {
  // A landmark with any observation farther than outlier_rad from its prediction is dropped (it
  // leaves the map; the front end keeps tracking it and it comes back as a new landmark).
  pose_cache_->invalidate();  // evaluated outside a solve: the window may have moved since
  int marked = 0;
  for (int i = 0; i < n_selected_; ++i) {
    Landmark& l = landmarks_->at_pool(chosen_[i]);
    if (!(l.inv_depth > 1.0 / options_.max_depth_m && l.inv_depth < 1.0 / options_.min_depth_m)) {
      l.has_depth = false;  // re-triangulated later
      continue;
    }
    bool bad = false;
    for_each_visual_edge(l, [&](const VisualEdge& e) {
      BearingResidual r;
      EdgeBlock blocks[5];
      const int nb = setup_visual_edge(l, e, 1.0, pose_cache_.get(), &r, blocks);
      const double* params[5];
      for (int b = 0; b < nb; ++b) {
        const EdgeBlock& eb = blocks[b];
        params[b] = eb.kind == EdgeBlock::kPose        ? window_->slot(eb.index).pose
                    : eb.kind == EdgeBlock::kExtrinsic ? window_->extrinsics().block(eb.index)
                                                       : &l.inv_depth;
      }
      double err = 0.0;
      bad = !r.error_rad(params, &err) || err > options_.outlier_rad;
      return !bad;
    });
    if (bad) {
      l.outlier = true;
      ++marked;
    }
  }
  stats_->outlier_landmarks += static_cast<std::uint64_t>(marked);
  return marked;
}

}  // namespace ums
