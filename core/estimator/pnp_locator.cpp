#include "core/estimator/pnp_locator.hpp"

#include "core/common/capacity.hpp"
#include "core/estimator/landmark_map.hpp"
#include "core/estimator/state_blocks.hpp"
#include "core/estimator/window.hpp"

namespace ums {

PnpLocator::PnpLocator(int min_inliers, double inlier_rad)
    : min_inliers_(min_inliers),
      inlier_rad_(inlier_rad),
      matches_(new PnpMatch[capacity::kMaxLandmarks]),
      mask_(new std::uint8_t[capacity::kMaxLandmarks]),
      landmark_(new std::int16_t[capacity::kMaxLandmarks]) {}

int PnpLocator::collect(const Window& window, const LandmarkMap& landmarks, int slot) {
  int n = 0;
  for (int k = 0; k < landmarks.size(); ++k) {
    const Landmark& l = landmarks[k];
    if (!l.has_depth || l.outlier || l.host_slot == slot) continue;
    const int o = l.find_obs(slot);
    if (o < 0) continue;
    PnpMatch& m = matches_[n];
    m.p_w = landmarks.point_w(l, window);
    m.cam = l.obs[o].has_left ? 0 : 1;
    m.bearing = (m.cam == 0 ? l.obs[o].bearing_left : l.obs[o].bearing_right).cast<double>().normalized();
    landmark_[n] = static_cast<std::int16_t>(landmarks.pool_index(k));
    ++n;
  }
  return n;
}

bool PnpLocator::locate(Window& window, LandmarkMap& landmarks, int slot, const Eigen::Isometry3d& prior) {
  const int n = collect(window, landmarks, slot);
  if (n < min_inliers_) return false;
  PnpOptions po;
  po.min_inliers = min_inliers_;
  po.inlier_rad = inlier_rad_;
  Eigen::Isometry3d T = prior;
  const PnpResult r = solve_pnp(matches_.get(), n, window.extrinsics().T_b_c_array(), po, &T, mask_.get());
  if (!r.ok) return false;
  pose_from_iso(T, window.slot(slot).pose);
  for (int k = 0; k < n; ++k)
    if (mask_[k] == 0) landmarks.at_pool(landmark_[k]).outlier = true;
  return true;
}

}  // namespace ums
