#pragma once
// The one wiring of a landmark's observations to bearing residuals (paper eq. 3 / 5): every
// observation other than the host one gives a residual; in the host frame (the other camera of
// the stereo pair) it depends on the two extrinsics and the inverse depth only, in another frame
// on the host and target poses, the extrinsics involved and the inverse depth. The solve
// (ProblemBuilder) and the outlier check iterate the same edges.

#include <Eigen/Core>

#include "core/common/capacity.hpp"
#include "core/estimator/bearing_residual.hpp"
#include "core/estimator/landmark.hpp"

namespace ums {

class RelativePoseCache;

// A parameter block an edge reads, named by what it is (the caller maps it to a solver id or to
// the values).
struct EdgeBlock {
  enum Kind : std::uint8_t { kPose, kExtrinsic, kInverseDepth, kTimeOffset } kind = kPose;
  int index = 0;  // window slot for kPose, camera for kExtrinsic
};
// The most blocks an edge reads (two poses, two extrinsics, inverse depth, time offset).
inline constexpr int kMaxEdgeBlocks = 6;

// Whether edges read the time offset block (estimate_td), and the offset each window slot's frame
// carries (WindowFrame::td_applied_s: the pipeline restamps new frames as td is refined).
struct EdgeTimeOffset {
  bool on = false;
  double td_applied_s[capacity::kWindowSize + 1] = {};  // s, by window slot
};

struct VisualEdge {
  int obs = 0;            // index in Landmark::obs
  int cam = 0;            // camera of the observation
  Eigen::Vector3d b;      // its bearing (unit, in that camera)
};

// Visits the landmark's edges in a fixed order (observations, then left before right); the
// visitor returns false to stop.
template <typename Visitor>
void for_each_visual_edge(const Landmark& l, Visitor&& visit) {
  for (int j = 0; j < l.n_obs; ++j) {
    const LandmarkObservation& o = l.obs[j];
    for (int cam = 0; cam < 2; ++cam) {
      if (!(cam == 0 ? o.has_left : o.has_right)) continue;
      if (o.slot == l.host_slot && cam == l.host_cam) continue;
      VisualEdge e;
      e.obs = j;
      e.cam = cam;
      e.b = (cam == 0 ? o.bearing_left : o.bearing_right).cast<double>();
      if (!visit(e)) return;
    }
  }
}

// Sets r up for edge e of landmark l with whitening weight w (1/rad; cache: optional, shared
// products for every edge) and writes the blocks it reads (at most kMaxEdgeBlocks), in the residual's
// order; returns their count. With td.on the edge also reads the time offset (last).
int setup_visual_edge(const Landmark& l, const VisualEdge& e, double w, RelativePoseCache* cache,
                      BearingResidual* r, EdgeBlock* blocks, const EdgeTimeOffset& td = {});

// Observation rays of a landmark (left and right per observation): at least two to be solved.
int count_rays(const Landmark& l);

}  // namespace ums
