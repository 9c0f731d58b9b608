// The loop closer's side of tightly coupled relocation (core/estimator/relocation.hpp): the
// request an accepted loop sends to the window, and the window's refined measurement coming back.

#include <algorithm>
#include <cmath>

#include "core/loop/loop_closer.hpp"

namespace ums::loop {

namespace {
constexpr double kDegPerRad = 180.0 / M_PI;
}

void LoopCloser::request_relocation(const KeyframeRecord& q, const KeyframeRecord& c, const LoopGeometry& g) {
  RelocationRequest& r = *request_;
  r.query = q.id;
  r.loop = c.id;
  r.odometry_epoch = epoch_;
  r.T_odom_q = q.T_odom_b;
  r.T_q_loop = g.T_c_q.inverse();
  r.matches.clear();
  if (&q != &db_->at(newest_slot_)) return;  // a query is always the newest keyframe
  const int n = verifier_.inlier_pairs(pair_q_.get(), pair_c_.get());
  for (int k = 0; k < n; ++k) {
    RelocationMatch m;
    m.landmark_id = newest_landmarks_[pair_q_[k]];
    m.bearing_c0 = c.features[pair_c_[k]].bearing_c0;
    m.p_loop_b = c.features[pair_c_[k]].p_b;
    if (r.matches.push_back(m) != Status::kOk) break;
  }
  has_request_ = true;
  ++stats_.relocation_requests;
}

bool LoopCloser::take_relocation(RelocationRequest* out) {
  if (!has_request_) return false;
  *out = *request_;
  has_request_ = false;
  return true;
}

std::int32_t LoopCloser::find_loop(FrameId query, FrameId loop) const {
  for (std::size_t l = n_loops_; l > 0; --l) {
    const LoopEdge& e = loops_[l - 1];
    if (db_->at(e.q_slot).id == query && db_->at(e.c_slot).id == loop) return static_cast<std::int32_t>(l - 1);
  }
  return -1;
}

void LoopCloser::on_relocated(const RelocationResult& result) {
  if (result.residuals == 0 || result.inliers < options_.min_relocation_inliers) {
    ++stats_.relocation_too_few;
    return;
  }
  const std::int32_t l = find_loop(result.query, result.loop);
  if (l < 0) {
    ++stats_.relocation_stale;
    return;
  }
  const Eigen::Isometry3d change = loops_[l].T_c_q.inverse() * result.T_loop_query;
  const double change_m = change.translation().norm();
  if (change_m > options_.relocation_max_change_m ||
      Eigen::AngleAxisd(change.linear()).angle() * kDegPerRad > options_.relocation_max_change_deg) {
    ++stats_.relocation_too_far;
    return;
  }
  // The two measurements see the place through different observations (the query keyframe's own
  // against the window frames' and the window's landmark estimates).
  const double w = options_.relocation_blend;
  Eigen::Isometry3d blended = Eigen::Isometry3d::Identity();
  const Eigen::Quaterniond q_v(loops_[l].T_c_q.linear()), q_r(result.T_loop_query.linear());
  blended.linear() = q_v.slerp(w, q_r).toRotationMatrix();
  blended.translation() = (1.0 - w) * loops_[l].T_c_q.translation() + w * result.T_loop_query.translation();
  if (!refine_loop(static_cast<std::size_t>(l), blended)) {
    ++stats_.relocation_refused;
    return;
  }
  ++stats_.relocations_refined;
  stats_.relocation_change_m_sum += change_m;
  RelocationResult noted = result;
  noted.T_loop_query = blended;
  note_refined(noted, static_cast<std::size_t>(l));
}

bool LoopCloser::refine_loop(std::size_t l, const Eigen::Isometry3d& T_c_q) {
  // The same consistency check as the loop's own: the graph must hold the refined measurement.
  save_map_state();
  const Eigen::Isometry3d verified = loops_[l].T_c_q;
  loops_[l].T_c_q = T_c_q;
  if (!solve_graph() || loop_residual_sigma(loops_[l]) > options_.max_loop_residual_sigma) {
    loops_[l].T_c_q = verified;
    restore_map_state();
    return false;
  }
  return true;
}

void LoopCloser::note_refined(const RelocationResult& result, std::size_t l) {
  const std::size_t n = num_events();
  for (std::size_t i = n; i > 0; --i) {
    const std::size_t first = n_events_ > capacity::kMaxLoopEvents ? n_events_ - capacity::kMaxLoopEvents : 0;
    LoopEvent& e = events_[(first + i - 1) % capacity::kMaxLoopEvents];
    if (e.query != result.query || e.loop != result.loop) continue;
    e.T_loop_query = result.T_loop_query;
    e.refined = true;
    e.p_map_query = db_->at(loops_[l].q_slot).T_map_b.translation();
    e.p_map_loop = db_->at(loops_[l].c_slot).T_map_b.translation();
    return;
  }
}

}  // namespace ums::loop
