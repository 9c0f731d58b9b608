#include "core/estimator/visual_edges.hpp"

#include "core/estimator/relative_pose_cache.hpp"

namespace ums {

namespace {

Eigen::Vector3d velocity(const LandmarkObservation& o, int cam) {
  return (cam == 0 ? o.velocity_left : o.velocity_right).cast<double>();
}

}  // namespace

int setup_visual_edge(const Landmark& l, const VisualEdge& e, double w, RelativePoseCache* cache,
                      BearingResidual* r, EdgeBlock* blocks, const EdgeTimeOffset& td) {
  const LandmarkObservation& o = l.obs[e.obs];
  const int h = l.host_slot;
  int nb = 0;
  if (o.slot == h) {
    r->set(BearingResidual::Kind::kSameFrame, false, l.b_host, e.b, w);
    if (cache != nullptr) r->bind(cache, h, l.host_cam, h, e.cam);
    blocks[nb++] = EdgeBlock{EdgeBlock::kExtrinsic, l.host_cam};
    blocks[nb++] = EdgeBlock{EdgeBlock::kExtrinsic, e.cam};
  } else {
    const bool same_cam = e.cam == l.host_cam;
    r->set(BearingResidual::Kind::kTwoFrames, same_cam, l.b_host, e.b, w);
    if (cache != nullptr) r->bind(cache, h, l.host_cam, o.slot, e.cam);
    blocks[nb++] = EdgeBlock{EdgeBlock::kPose, h};
    blocks[nb++] = EdgeBlock{EdgeBlock::kPose, o.slot};
    blocks[nb++] = EdgeBlock{EdgeBlock::kExtrinsic, l.host_cam};
    if (!same_cam) blocks[nb++] = EdgeBlock{EdgeBlock::kExtrinsic, e.cam};
  }
  blocks[nb++] = EdgeBlock{EdgeBlock::kInverseDepth, 0};
  if (td.on) {
    const int ho = l.find_obs(h);
    const Eigen::Vector3d v_host = ho < 0 ? Eigen::Vector3d::Zero() : velocity(l.obs[ho], l.host_cam);
    r->set_time_offset(v_host, velocity(o, e.cam), td.td_applied_s[h], td.td_applied_s[o.slot]);
    blocks[nb++] = EdgeBlock{EdgeBlock::kTimeOffset, 0};
  }
  return nb;
}

int count_rays(const Landmark& l) {
  int rays = 0;
  for (int j = 0; j < l.n_obs; ++j) rays += static_cast<int>(l.obs[j].has_left) + static_cast<int>(l.obs[j].has_right);
  return rays;
}

}  // namespace ums
