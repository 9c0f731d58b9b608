#include "core/estimator/landmark_map.hpp"

#include <algorithm>
#include <cmath>

#include "core/estimator/geometry.hpp"
#include "core/estimator/window.hpp"

namespace ums {

LandmarkMap::LandmarkMap(const LandmarkMapOptions& options)
    : options_(options),
      pool_(std::make_unique<Pool<Landmark, capacity::kMaxLandmarks>>()),
      ids_(new std::uint32_t[kCapacity]),
      index_(new std::int16_t[kCapacity]) {}

int LandmarkMap::find(std::uint32_t id) const {
  const std::uint32_t* begin = ids_.get();
  const std::uint32_t* end = begin + n_;
  const std::uint32_t* it = std::lower_bound(begin, end, id);
  if (it == end || *it != id) return -1;
  return index_[it - begin];
}

int LandmarkMap::create(std::uint32_t id) {
  Landmark* l = pool_->acquire();
  if (l == nullptr) return -1;
  const int idx = static_cast<int>(pool_->index_of(l));
  l->id = id;
  int pos = n_;
  while (pos > 0 && ids_[pos - 1] > id) {
    ids_[pos] = ids_[pos - 1];
    index_[pos] = index_[pos - 1];
    --pos;
  }
  ids_[pos] = id;
  index_[pos] = static_cast<std::int16_t>(idx);
  ++n_;
  return idx;
}

bool LandmarkMap::too_far_for_stereo(const FeatureObservation& o, const Eigen::Matrix3d& R_c0_c1) const {
  if (options_.min_stereo_parallax_rad <= 0.0 || !o.has_left() || !o.has_right()) return false;
  const Eigen::Vector3d b_r = R_c0_c1 * o.bearing_right.cast<double>();
  const double parallax_rad = std::atan2(o.bearing_left.cast<double>().cross(b_r).norm(),
                                         o.bearing_left.cast<double>().dot(b_r));
  return parallax_rad < options_.min_stereo_parallax_rad;
}

namespace {

// One camera's bearing rate between consecutive frames: the new observation gets the backward
// difference; the previous one the mean of its backward difference and this one (a central
// difference, centred on its own time), or this one alone when it was the track's first (often
// the landmark's host: a host without a rate would leave its ray unmoved by the offset). With the
// gyro (m.valid) only the translational part is differenced: the spin -w x b is exact at each
// frame's own time, so the newest frame's rate does not lag by half a frame.
void difference(const Eigen::Vector3f& b_prev, const Eigen::Vector3f& b_new, float inv_dt, bool prev_had_rate,
                const CameraMotion& m, int cam, Eigen::Vector3f* v_prev, Eigen::Vector3f* v_new) {
  if (!m.valid) {
    *v_new = (b_new - b_prev) * inv_dt;
    *v_prev = prev_had_rate ? Eigen::Vector3f(0.5f * (*v_prev + *v_new)) : *v_new;
    return;
  }
  const Eigen::Vector3f spin_prev = -m.w_prev_rad_s[cam].cross(b_prev);
  const Eigen::Vector3f u_new = (b_new - m.R_cur_prev[cam] * b_prev) * inv_dt;  // in the camera now
  const Eigen::Vector3f u_at_prev = m.R_cur_prev[cam].transpose() * u_new;
  *v_new = -m.w_cur_rad_s[cam].cross(b_new) + u_new;
  *v_prev = spin_prev + (prev_had_rate ? Eigen::Vector3f(0.5f * (*v_prev - spin_prev + u_at_prev)) : u_at_prev);
}

// The rate of a sighting without one in the frame before: its spin, or nothing without the gyro.
void spin_only(const CameraMotion& m, LandmarkObservation* ob) {
  ob->velocity_left.setZero();
  ob->velocity_right.setZero();
  ob->has_rate_left = false;  // a pool slot may hold an earlier landmark's flags
  ob->has_rate_right = false;
  if (!m.valid) return;
  if (ob->has_left) ob->velocity_left = -m.w_cur_rad_s[0].cross(ob->bearing_left);
  if (ob->has_right) ob->velocity_right = -m.w_cur_rad_s[1].cross(ob->bearing_right);
}

// The bearing rates of `ob` (and the central ones of `last`) when the landmark's previous
// observation was in prev_slot, the frame before.
void set_velocities(LandmarkObservation* last, int prev_slot, double dt_s, const CameraMotion& m,
                    LandmarkObservation* ob) {
  spin_only(m, ob);
  if (last == nullptr || last->slot != prev_slot || !(dt_s > 0.0)) return;
  const float inv_dt = static_cast<float>(1.0 / dt_s);
  if (last->has_left && ob->has_left)
    difference(last->bearing_left, ob->bearing_left, inv_dt, last->has_rate_left, m, 0, &last->velocity_left,
               &ob->velocity_left);
  if (last->has_right && ob->has_right)
    difference(last->bearing_right, ob->bearing_right, inv_dt, last->has_rate_right, m, 1, &last->velocity_right,
               &ob->velocity_right);
  ob->has_rate_left = last->has_left && ob->has_left;
  ob->has_rate_right = last->has_right && ob->has_right;
}

}  // namespace

int LandmarkMap::ingest(const FrameFeatures& ff, int slot, const Eigen::Matrix3d& R_c0_c1, int prev_slot,
                        double dt_s, const CameraMotion& motion) {
  int dropped = 0;
  for (const FeatureObservation& o : ff.features) {
    const bool far = too_far_for_stereo(o, R_c0_c1);
    int idx = find(o.id);
    if (idx < 0) {
      idx = create(o.id);
      if (idx < 0) {
        ++dropped;
        continue;
      }
      Landmark& l = at_pool(idx);
      l.host_slot = static_cast<std::uint8_t>(slot);
      l.host_cam = o.has_left() ? 0 : 1;
      l.b_host = (o.has_left() ? o.bearing_left : o.bearing_right).cast<double>().normalized();
    }
    Landmark& l = at_pool(idx);
    if (l.n_obs >= capacity::kMaxObservationsPerLandmark) continue;  // cannot happen: one per frame
    LandmarkObservation* last = l.n_obs > 0 ? &l.obs[l.n_obs - 1] : nullptr;
    LandmarkObservation& ob = l.obs[l.n_obs++];
    ob.slot = static_cast<std::uint8_t>(slot);
    ob.has_left = o.has_left();
    ob.has_right = o.has_right() && !far;
    ob.bearing_left = o.bearing_left;
    ob.bearing_right = o.bearing_right;
    set_velocities(last, prev_slot, dt_s, motion, &ob);
    if (o.cls == FeatureClass::k3D && !far) l.stereo = true;
    l.track_length = o.track_length;
    // A host seen only on the right and later on the left keeps its right host (ids of 2D-right
    // tracks never become left tracks in the front end).
  }
  return dropped;
}

Eigen::Vector3d LandmarkMap::point_w(const Landmark& l, const Window& window) const {
  return window.T_w_b(l.host_slot) * (window.extrinsics().T_b_c(l.host_cam) * (l.b_host / l.inv_depth));
}

void LandmarkMap::rehost(Landmark& l, const Window& window, Rehost how) const {
  // The host frame leaves the window: move the depth to the earliest remaining observation.
  if (l.n_obs == 0) return;
  const LandmarkObservation& first = l.obs[0];
  const int new_cam = first.has_left ? 0 : 1;
  Eigen::Vector3d b_new = (new_cam == 0 ? first.bearing_left : first.bearing_right).cast<double>().normalized();
  if (l.has_depth) {
    const Eigen::Vector3d P_w = point_w(l, window);
    const Eigen::Vector3d P_c = (window.T_w_b(first.slot) * window.extrinsics().T_b_c(new_cam)).inverse() * P_w;
    const double d = P_c.norm();
    if (P_c.dot(b_new) > 0.0 && d > options_.min_depth_m && d < options_.max_depth_m) {
      l.inv_depth = 1.0 / d;
      if (how == Rehost::kKeepPoint) b_new = P_c / d;
    } else {
      l.has_depth = false;
    }
  }
  l.host_slot = first.slot;
  l.host_cam = static_cast<std::uint8_t>(new_cam);
  l.b_host = b_new;
}

void LandmarkMap::remove_frame(int slot, const Window& window, Rehost how) {
  for (int k = 0; k < n_; ++k) {
    Landmark& l = (*this)[k];
    const int o = l.find_obs(slot);
    if (o < 0) continue;
    const bool was_host = l.host_slot == slot;
    for (int j = o; j + 1 < l.n_obs; ++j) l.obs[j] = l.obs[j + 1];
    --l.n_obs;
    if (was_host) rehost(l, window, how);
  }
  compact();
}

void LandmarkMap::clear_observations() {
  for (int k = 0; k < n_; ++k) (*this)[k].n_obs = 0;
  compact();
}

void LandmarkMap::compact() {
  int w = 0;
  for (int k = 0; k < n_; ++k) {
    const int idx = index_[k];
    Landmark& l = at_pool(idx);
    if (l.n_obs == 0 || l.outlier) {
      pool_->release(&l);
      continue;
    }
    ids_[w] = ids_[k];
    index_[w] = index_[k];
    ++w;
  }
  n_ = w;
}

bool LandmarkMap::triangulate(Landmark& l, const Window& window, int exclude_slot) const {
  Ray rays[2 * capacity::kMaxObservationsPerLandmark];
  int n = 0;
  // Host ray first: the angle test is against it.
  const int ho = l.find_obs(l.host_slot);
  if (ho < 0) return false;
  auto add_ray = [&](int slot, int cam, const Eigen::Vector3f& b) {
    const Eigen::Isometry3d T_w_c = window.T_w_b(slot) * window.extrinsics().T_b_c(cam);
    rays[n].origin = T_w_c.translation();
    rays[n].direction = (T_w_c.linear() * b.cast<double>()).normalized();
    ++n;
  };
  const LandmarkObservation& h = l.obs[ho];
  add_ray(l.host_slot, l.host_cam, l.host_cam == 0 ? h.bearing_left : h.bearing_right);
  for (int k = 0; k < l.n_obs; ++k) {
    const LandmarkObservation& o = l.obs[k];
    if (o.slot == exclude_slot && o.slot != l.host_slot) continue;
    if (o.has_left && !(k == ho && l.host_cam == 0)) add_ray(o.slot, 0, o.bearing_left);
    if (o.has_right && !(k == ho && l.host_cam == 1)) add_ray(o.slot, 1, o.bearing_right);
  }
  const TriangulationResult r = ums::triangulate(rays, n, options_.min_triangulation_angle_deg * M_PI / 180.0);
  if (!r.ok) return false;
  const Eigen::Vector3d P_c =
      (window.T_w_b(l.host_slot) * window.extrinsics().T_b_c(l.host_cam)).inverse() * r.p_w;
  const double d = P_c.norm();
  if (P_c.dot(l.b_host) <= 0.0 || d < options_.min_depth_m || d > options_.max_depth_m) return false;
  l.inv_depth = 1.0 / d;
  l.has_depth = true;
  return true;
}

void LandmarkMap::triangulate_all(const Window& window, int exclude_slot) {
  for (int k = 0; k < n_; ++k) {
    Landmark& l = (*this)[k];
    if (!l.has_depth && !l.outlier) triangulate(l, window, exclude_slot);
  }
}

int LandmarkMap::count_depth_observations(int slot, int* n_2d_with_depth) const {
  int n = 0, n2d = 0;
  for (int k = 0; k < n_; ++k) {
    const Landmark& l = (*this)[k];
    if (!l.has_depth || l.outlier) continue;
    const int o = l.find_obs(slot);
    if (o < 0 || l.host_slot == slot) continue;
    ++n;
    if (!(l.obs[o].has_left && l.obs[o].has_right)) ++n2d;
  }
  if (n_2d_with_depth != nullptr) *n_2d_with_depth = n2d;
  return n;
}

void LandmarkMap::save_depths(DepthBackup* b) const {
  for (int k = 0; k < n_; ++k) {
    const Landmark& l = (*this)[k];
    b->inv_depth[index_[k]] = l.inv_depth;
    b->has_depth[index_[k]] = l.has_depth;
  }
}

void LandmarkMap::restore_depths(const DepthBackup& b) {
  for (int k = 0; k < n_; ++k) {
    Landmark& l = (*this)[k];
    l.inv_depth = b.inv_depth[index_[k]];
    l.has_depth = b.has_depth[index_[k]];
  }
}

}  // namespace ums
