#include "core/estimator/marginalizer.hpp"

#include <utility>

#include "core/estimator/landmark_map.hpp"
#include "core/estimator/window.hpp"
#include "solver/marginal_prior.hpp"
#include "solver/problem.hpp"

namespace ums {

Marginalizer::Marginalizer()
    : prior_(std::make_unique<solver::MarginalPrior>()),
      prior_next_(std::make_unique<solver::MarginalPrior>()),
      record_(std::make_unique<MarginalizedKeyframe>()) {}

Marginalizer::~Marginalizer() = default;

namespace {

// A frame's pose or speed-bias (the prior's other blocks belong to the rig).
bool is_frame_block(const BlockName& nm) { return nm.kind == BlockKind::kPose || nm.kind == BlockKind::kSpeedBias; }

}  // namespace

bool Marginalizer::empty() const { return prior_->empty(); }
void Marginalizer::clear() { prior_->clear(); }
int Marginalizer::num_blocks() const { return prior_->num_blocks(); }

bool Marginalizer::adopt(solver::Problem& problem, const BlockTable& table, const int* ids, int n) {
  const solver::SolverStatus st = problem.marginalize(ids, n, prior_next_.get());
  if (st != solver::SolverStatus::kOk) {
    // The information is lost, the window goes on: counted, never fatal.
    prior_->clear();
    return false;
  }
  for (int i = 0; i < prior_next_->num_blocks(); ++i) names_[i] = table[prior_next_->block(i).source_id];
  std::swap(prior_, prior_next_);
  return true;
}

bool Marginalizer::holds_frame(FrameId id) const {
  for (int i = 0; i < prior_->num_blocks(); ++i)
    if (is_frame_block(names_[i]) && names_[i].owner == id) return true;
  return false;
}

bool Marginalizer::marginalize_frame(FrameId id, Window& window, solver::Problem& problem, BlockTable* table) {
  if (!holds_frame(id)) return true;
  problem.clear();
  solver::BlockId ids[solver::capacity::kMaxReducedBlocks];
  for (int i = 0; i < prior_->num_blocks(); ++i) {
    const BlockName& nm = names_[i];
    if (nm.kind == BlockKind::kExtrinsic) {
      problem.add_pose_block(window.extrinsics().block(static_cast<int>(nm.owner)), &ids[i]);
    } else if (nm.kind == BlockKind::kTimeOffset) {
      problem.add_euclidean_block(window.time_offset().block(), 1, &ids[i]);
    } else if (nm.kind == BlockKind::kGyroScale) {
      problem.add_euclidean_block(window.gyro_scale().block(), 3, &ids[i]);
    } else {
      WindowFrame& f = window.slot(window.slot_of_id(nm.owner));
      if (nm.kind == BlockKind::kSpeedBias) {
        problem.add_euclidean_block(f.sb, state::kSbSize, &ids[i]);
      } else {
        problem.add_pose_block(f.pose, &ids[i]);
      }
    }
    table->note(ids[i], nm.kind, nm.owner);
  }
  problem.add_prior(prior_.get(), ids);
  solver::BlockId marg[2];
  int n = 0;
  for (int i = 0; i < prior_->num_blocks(); ++i)
    if (is_frame_block(names_[i]) && names_[i].owner == id) marg[n++] = ids[i];
  return adopt(problem, *table, marg, n);
}

void Marginalizer::emit_keyframe(const Window& window, int pos, const LandmarkMap& landmarks,
                                 std::uint32_t odometry_epoch, bool gravity_aligned) {
  if (sink_ == nullptr) return;
  const WindowFrame& f = window.at(pos);
  const int slot = window.slot_at(pos);
  MarginalizedKeyframe& k = *record_;
  k.id = f.id;
  k.t_ns = f.t_ns;
  k.odometry_epoch = odometry_epoch;
  k.gravity_aligned = gravity_aligned;
  k.T_odom_b = window.T_w_b(slot);
  k.observations.clear();
  for (int i = 0; i < landmarks.size(); ++i) {
    const Landmark& l = landmarks[i];
    const int o = l.find_obs(slot);
    if (o < 0 || l.outlier) continue;
    KeyframeObservation ko;
    ko.landmark_id = l.id;
    ko.has_left = l.obs[o].has_left;
    ko.has_right = l.obs[o].has_right;
    ko.stereo = l.stereo;
    ko.bearing_left = l.obs[o].bearing_left;
    ko.bearing_right = l.obs[o].bearing_right;
    ko.has_point = l.has_depth;
    if (l.has_depth) ko.p_odom = landmarks.point_w(l, window);
    if (k.observations.push_back(ko) != Status::kOk) break;
  }
  ++emitted_;
  sink_->on_keyframe(k);
}

}  // namespace ums
