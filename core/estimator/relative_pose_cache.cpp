#include "core/estimator/relative_pose_cache.hpp"

#include <Eigen/Geometry>

#include "core/common/assert.hpp"

namespace ums {

void RelativePoseCache::bind_frame(int slot, const double* pose) {
  UMS_ASSERT(slot >= 0 && slot < kMaxFrames);
  frame_[slot].values = pose;
  invalidate();
}

void RelativePoseCache::bind_extrinsic(int cam, const double* T_b_c) {
  UMS_ASSERT(cam >= 0 && cam < kCameras);
  ext_[cam].values = T_b_c;
  invalidate();
}

void RelativePoseCache::refresh(Source& s) {
  if (s.epoch == epoch_) return;
  s.epoch = epoch_;
  // The solver keeps quaternions unit (its plus renormalizes), as the residual assumed before.
  s.R = Eigen::Map<const Eigen::Quaterniond>(s.values + 3).toRotationMatrix();
  s.p = Eigen::Vector3d(s.values[0], s.values[1], s.values[2]);
}

const RelativePoseCache::Pair& RelativePoseCache::form(Entry& e, int host_slot, int host_cam, int target_slot,
                                                       int target_cam) {
  Source& h = frame_[host_slot];
  Source& t = frame_[target_slot];
  Source& eh = ext_[host_cam];
  Source& et = ext_[target_cam];
  refresh(h);
  refresh(t);
  refresh(eh);
  refresh(et);
  Pair& c = e.pair;
  c.R_b_ch = eh.R;
  c.p_b_ch = eh.p;
  c.R_b_ct = et.R;
  c.p_b_ct = et.p;
  // P_ct = R_b_ct^T (R_w_bt^T (R_w_bh (R_b_ch P_ch + p_b_ch) + p_w_bh - p_w_bt) - p_b_ct)
  c.R_ct_w.noalias() = et.R.transpose() * t.R.transpose();
  c.R_ct_bh.noalias() = c.R_ct_w * h.R;
  c.R_ct_ch.noalias() = c.R_ct_bh * eh.R;
  c.p_ct_ch.noalias() = c.R_ct_bh * eh.p + c.R_ct_w * (h.p - t.p) - et.R.transpose() * et.p;
  e.epoch = epoch_;
  return c;
}

const RelativePoseCache::CameraPair& RelativePoseCache::form_cameras(CameraEntry& e, int host_cam, int target_cam) {
  Source& eh = ext_[host_cam];
  Source& et = ext_[target_cam];
  refresh(eh);
  refresh(et);
  e.pair.R_ct_ch.noalias() = et.R.transpose() * eh.R;
  e.pair.p_ct_ch.noalias() = et.R.transpose() * (eh.p - et.p);
  e.epoch = epoch_;
  return e.pair;
}

}  // namespace ums
