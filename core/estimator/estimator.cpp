#include "core/estimator/estimator.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>

#include "core/estimator/geometry.hpp"
#include "core/estimator/imu_alignment.hpp"
#include "core/math/so3.hpp"
#include "solver/marginal_prior.hpp"
#include "solver/problem.hpp"

namespace ums {
namespace {

constexpr int kMaxVisualResiduals = static_cast<int>(capacity::kMaxVisualResiduals);
constexpr int kMaxLandmarks = static_cast<int>(capacity::kMaxLandmarks);
constexpr int kRecentImu = static_cast<int>(capacity::kStandstillImuSamples);
constexpr std::uint8_t kKindPose = 0, kKindSpeedBias = 1, kKindExtrinsic = 2, kKindLandmark = 3;

double ms_since(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
}

void pose_from_iso(const Eigen::Isometry3d& T, double* x) {
  const Eigen::Quaterniond q(T.linear());
  x[0] = T.translation().x();
  x[1] = T.translation().y();
  x[2] = T.translation().z();
  x[3] = q.x();
  x[4] = q.y();
  x[5] = q.z();
  x[6] = q.w();
}

Eigen::Isometry3d iso_from_pose(const double* x) {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = Eigen::Quaterniond(x[6], x[3], x[4], x[5]).normalized().toRotationMatrix();
  T.translation() = Eigen::Vector3d(x[0], x[1], x[2]);
  return T;
}

Eigen::Quaterniond quat_of(const double* pose) { return Eigen::Quaterniond(pose[6], pose[3], pose[4], pose[5]); }

void set_quat(double* pose, const Eigen::Quaterniond& q_in) {
  const Eigen::Quaterniond q = q_in.normalized();
  pose[3] = q.x();
  pose[4] = q.y();
  pose[5] = q.z();
  pose[6] = q.w();
}

// Minimal rotation taking unit-free direction a onto b.
Eigen::Matrix3d rotation_between(const Eigen::Vector3d& a, const Eigen::Vector3d& b) {
  return Eigen::Quaterniond::FromTwoVectors(a, b).toRotationMatrix();
}

}  // namespace

struct Estimator::Backup {
  double pose[kSlots][7];
  double sb[kSlots][9];
  double inv_depth[capacity::kMaxLandmarks];
  bool has_depth[capacity::kMaxLandmarks];
};

Estimator::Estimator(const EstimatorOptions& options, const RigCalibration& rig)
    : options_(options),
      rig_(rig),
      g_w_(0.0, 0.0, -options.gravity_m_s2),
      keyframes_(options.keyframe),
      nav_(Eigen::Vector3d(0.0, 0.0, -options.gravity_m_s2)) {
  options_.validate();
  options_.preintegration.noise = ImuNoise::from_calibration(rig.imu);
  options_.preintegration.noise.gyro_noise_density *= options_.imu_noise_inflation;
  options_.preintegration.noise.accel_noise_density *= options_.imu_noise_inflation;
  options_.preintegration.noise.gyro_random_walk *= options_.imu_noise_inflation;
  options_.preintegration.noise.accel_random_walk *= options_.imu_noise_inflation;
  options_.preintegration.validate();
  weight_left_ = options_.focal_px / options_.sigma_px * options_.beta_left;
  weight_right_ = options_.focal_px / options_.sigma_px * options_.beta_right;
  for (int c = 0; c < 2; ++c) {
    T_b_c_iso_[c] = rig.imu.T_b_i.inverse() * rig.cam[c].T_b_c;  // camera -> IMU body
    pose_from_iso(T_b_c_iso_[c], T_b_c_[c]);
  }

  slots_.reset(new FrameState[kSlots]);
  for (int s = 0; s < kSlots; ++s) slots_[s].pre = Preintegration(options_.preintegration);
  landmarks_.reset(new Landmark[kMaxLandmarks]);
  free_list_.reset(new std::int16_t[kMaxLandmarks]);
  for (int i = 0; i < kMaxLandmarks; ++i) free_list_[i] = static_cast<std::int16_t>(kMaxLandmarks - 1 - i);
  n_free_ = kMaxLandmarks;
  lm_index_id_.reset(new std::uint32_t[kMaxLandmarks]);
  lm_index_.reset(new std::int16_t[kMaxLandmarks]);
  recent_.reset(new ImuSample[kRecentImu]);
  scratch_samples_.reset(new ImuSample[kRecentImu]);

  problem_ = std::make_unique<solver::Problem>();
  prior_ = std::make_unique<solver::MarginalPrior>();
  prior_next_ = std::make_unique<solver::MarginalPrior>();
  visual_.reset(new BearingResidual[kMaxVisualResiduals]);
  static_assert(kSlots <= RelativePoseCache::kMaxFrames, "the pose cache holds every frame slot");
  pose_cache_ = std::make_unique<RelativePoseCache>();
  for (int s = 0; s < kSlots; ++s) pose_cache_->bind_frame(s, slots_[s].pose);
  for (int c = 0; c < 2; ++c) pose_cache_->bind_extrinsic(c, T_b_c_[c]);
  problem_->set_evaluation_callback(pose_cache_.get());
  visual_landmark_.reset(new int[kMaxVisualResiduals]);
  selected_.reset(new std::int16_t[kMaxLandmarks]);
  candidates_.reset(new int[kMaxLandmarks]);
  block_of_landmark_.reset(new int[kMaxLandmarks]);
  block_kind_.reset(new std::uint8_t[solver::capacity::kMaxParameterBlocks]);
  block_slot_.reset(new std::int8_t[solver::capacity::kMaxParameterBlocks]);
  backup_a_ = std::make_unique<Backup>();
  backup_b_ = std::make_unique<Backup>();
  pnp_matches_.reset(new PnpMatch[kMaxLandmarks]);
  pnp_mask_.reset(new std::uint8_t[kMaxLandmarks]);
  pnp_landmark_.reset(new std::int16_t[kMaxLandmarks]);

  SpeedBiasPrior::Vector9 zero = SpeedBiasPrior::Vector9::Zero();
  SpeedBiasPrior::Vector9 sigma_v = SpeedBiasPrior::Vector9::Zero();
  sigma_v.head<3>().setConstant(options_.still_sigma_v);
  zero_velocity_.set(zero, sigma_v);
  still_.set(options_.still_sigma_m, options_.still_sigma_rad);
  next_slot_ = 0;
}

Estimator::~Estimator() = default;

std::size_t Estimator::footprint_bytes() const {
  return sizeof(*this) + kSlots * sizeof(FrameState) + kMaxLandmarks * (sizeof(Landmark) + 2 + 4 + 2 + 2 + 4 + 4) +
         kRecentImu * sizeof(ImuSample) + kRecentImu * sizeof(ImuSample) +
         sizeof(solver::Problem) + 2 * sizeof(solver::MarginalPrior) +
         kMaxVisualResiduals * (sizeof(BearingResidual) + sizeof(int)) + sizeof(RelativePoseCache) +
         solver::capacity::kMaxParameterBlocks * 2 + 2 * sizeof(Backup);
}

// ---------------------------------------------------------------------------------------------
// IMU

void Estimator::add_imu(const ImuSample& in, bool saturated) {
  if (have_imu_ && in.t_ns <= last_imu_.t_ns) {
    ++stats_.imu_out_of_order;
    return;
  }
  // A sample the saturation element had to clip is an impulse, not motion: even clipped it
  // carries up to one bound of false increment (30 m/s^2 for 5 ms is 0.15 m/s, over a hundred
  // sigmas of a 50 ms interval), so the previous sample is held in its place.
  ImuSample sample = in;
  if (saturated && have_imu_) {
    sample = last_imu_;
    sample.t_ns = in.t_ns;
    ++stats_.imu_held;
  }
  if (!have_imu_) {
    // Attitude from the first specific force: right at rest, a few degrees off in motion, and
    // corrected by the first standstill or the visual-IMU alignment.
    NavState s;
    s.q_w_b = attitude_from_gravity(sample.accel_m_s2);
    nav_.reset(s, sample);
    attitude_known_ = true;
  } else {
    nav_.propagate(sample);
  }
  recent_[recent_head_] = sample;
  recent_head_ = (recent_head_ + 1) % kRecentImu;
  if (recent_count_ < kRecentImu) ++recent_count_;

  FrameState& next = slots_[next_slot_];
  if (next_pre_started_) {
    if (next.pre.add(sample) == Status::kFull) ++stats_.drops_imu;
  }
  last_imu_ = sample;
  have_imu_ = true;
}

bool Estimator::imu_rate_state(NavState* state) const {
  if (!nav_.initialized() || (mode_ == EstimatorMode::kImuOnly && !velocity_known_)) return false;
  *state = nav_.state();
  return true;
}

void Estimator::close_interval(FrameState& f) {
  // The boundary sample at the frame time: the last sample held (samples arrive in time order,
  // so all before the frame are in; holding the last <= 1/rate_hz is well below the noise).
  if (have_imu_ && next_pre_started_ && last_imu_.t_ns < f.t_ns) {
    ImuSample boundary = last_imu_;
    boundary.t_ns = f.t_ns;
    if (f.pre.add(boundary) == Status::kFull) ++stats_.drops_imu;
  }
  f.imu_ok = next_pre_started_ && f.pre.num_samples() >= 2 && f.imu.residual().init(&f.pre, g_w_) == Status::kOk;
}

bool Estimator::check_standstill(std::int64_t t_ns, StandstillResult* result) {
  const std::int64_t window_ns = static_cast<std::int64_t>(options_.standstill_window_s * 1e9);
  int n = 0;
  // Copy the samples of [t - window, t] out of the ring, oldest first.
  for (int k = 0; k < recent_count_; ++k) {
    const int idx = (recent_head_ - recent_count_ + k + kRecentImu) % kRecentImu;
    const ImuSample& s = recent_[idx];
    if (s.t_ns < t_ns - window_ns || s.t_ns > t_ns) continue;
    scratch_samples_[n++] = s;
  }
  ImuNoise noise = ImuNoise::from_calibration(rig_.imu);
  const Status st = detect_standstill(scratch_samples_.get(), static_cast<std::size_t>(n), noise,
                                      options_.standstill, result);
  // A window shorter than asked (start of the data) is not trusted.
  if (st != Status::kOk) return false;
  if (n > 1 && (scratch_samples_[n - 1].t_ns - scratch_samples_[0].t_ns) < window_ns * 9 / 10) return false;
  return result->at_rest;
}

// ---------------------------------------------------------------------------------------------
// Window and landmarks

static_assert(capacity::kStandstillImuSamples >= capacity::kMaxImuSamplesBetweenFrames,
              "the standstill scratch also holds one interval's samples when two are merged");

int Estimator::position_of(int slot) const {
  for (int k = 0; k < n_; ++k)
    if (order_[k] == slot) return k;
  return -1;
}

Eigen::Isometry3d Estimator::T_w_b(int slot) const { return iso_from_pose(slots_[slot].pose); }

int Estimator::find_landmark(std::uint32_t id) const {
  const std::uint32_t* begin = lm_index_id_.get();
  const std::uint32_t* end = begin + n_lm_index_;
  const std::uint32_t* it = std::lower_bound(begin, end, id);
  if (it == end || *it != id) return -1;
  return lm_index_[it - begin];
}

int Estimator::create_landmark(std::uint32_t id) {
  if (n_free_ == 0) {
    ++stats_.drops_landmarks;
    return -1;
  }
  const int idx = free_list_[--n_free_];
  Landmark& l = landmarks_[idx];
  l = Landmark{};
  l.id = id;
  // Keep the index sorted by id: ids grow over the run, so this is almost always an append.
  int pos = n_lm_index_;
  while (pos > 0 && lm_index_id_[pos - 1] > id) {
    lm_index_id_[pos] = lm_index_id_[pos - 1];
    lm_index_[pos] = lm_index_[pos - 1];
    --pos;
  }
  lm_index_id_[pos] = id;
  lm_index_[pos] = static_cast<std::int16_t>(idx);
  ++n_lm_index_;
  stats_.peak_landmarks = std::max(stats_.peak_landmarks, static_cast<std::size_t>(n_lm_index_));
  return idx;
}

void Estimator::ingest(const FrameFeatures& ff, int slot) {
  for (const FeatureObservation& o : ff.features) {
    int idx = find_landmark(o.id);
    if (idx < 0) {
      idx = create_landmark(o.id);
      if (idx < 0) continue;
      Landmark& l = landmarks_[idx];
      l.host_slot = static_cast<std::uint8_t>(slot);
      l.host_cam = o.has_left() ? 0 : 1;
      l.b_host = (o.has_left() ? o.bearing_left : o.bearing_right).cast<double>().normalized();
    }
    Landmark& l = landmarks_[idx];
    if (l.n_obs >= capacity::kMaxObservationsPerLandmark) continue;  // cannot happen: one per frame
    LandmarkObservation& ob = l.obs[l.n_obs++];
    ob.slot = static_cast<std::uint8_t>(slot);
    ob.has_left = o.has_left();
    ob.has_right = o.has_right();
    ob.bearing_left = o.bearing_left;
    ob.bearing_right = o.bearing_right;
    if (o.cls == FeatureClass::k3D) l.stereo = true;
    l.track_length = o.track_length;
    // A host seen only on the right and later on the left keeps its right host (ids of 2D-right
    // tracks never become left tracks in the front end).
  }
}

void Estimator::rehost(Landmark& l) {
  // The host frame leaves the window: move the depth to the earliest remaining observation.
  if (l.n_obs == 0) return;
  const LandmarkObservation& first = l.obs[0];
  const int new_cam = first.has_left ? 0 : 1;
  const Eigen::Vector3d b_new = (new_cam == 0 ? first.bearing_left : first.bearing_right).cast<double>().normalized();
  if (l.has_depth) {
    const Eigen::Vector3d P_w = T_w_b(l.host_slot) * (T_b_c_iso_[l.host_cam] * (l.b_host / l.inv_depth));
    const Eigen::Vector3d P_c = (T_w_b(first.slot) * T_b_c_iso_[new_cam]).inverse() * P_w;
    const double d = P_c.norm();
    if (P_c.dot(b_new) > 0.0 && d > options_.min_depth_m && d < options_.max_depth_m) {
      l.inv_depth = 1.0 / d;
    } else {
      l.has_depth = false;
    }
  }
  l.host_slot = first.slot;
  l.host_cam = static_cast<std::uint8_t>(new_cam);
  l.b_host = b_new;
}

void Estimator::remove_slot(int pos) {
  const int slot = order_[pos];
  for (int k = 0; k < n_lm_index_; ++k) {
    Landmark& l = landmarks_[lm_index_[k]];
    const int o = l.find_obs(slot);
    if (o < 0) continue;
    // Keep the positions computed before the shift: the host's pose is needed for rehosting.
    const bool was_host = l.host_slot == slot;
    LandmarkObservation removed = l.obs[o];
    (void)removed;
    for (int j = o; j + 1 < l.n_obs; ++j) l.obs[j] = l.obs[j + 1];
    --l.n_obs;
    if (was_host) rehost(l);
  }
  for (int k = pos; k + 1 < n_; ++k) order_[k] = order_[k + 1];
  --n_;
  if (init_prior_slot_ == slot) init_prior_slot_ = -1;
  compact_landmarks();
}

void Estimator::compact_landmarks() {
  int w = 0;
  for (int k = 0; k < n_lm_index_; ++k) {
    const int idx = lm_index_[k];
    const Landmark& l = landmarks_[idx];
    if (l.n_obs == 0 || l.outlier) {
      free_list_[n_free_++] = static_cast<std::int16_t>(idx);
      continue;
    }
    lm_index_id_[w] = lm_index_id_[k];
    lm_index_[w] = lm_index_[k];
    ++w;
  }
  n_lm_index_ = w;
}

void Estimator::reset_window(bool keep_newest) {
  const int keep = keep_newest && n_ > 0 ? order_[n_ - 1] : -1;
  while (n_ > (keep >= 0 ? 1 : 0)) remove_slot(0);
  if (keep < 0) {
    for (int k = 0; k < n_lm_index_; ++k) landmarks_[lm_index_[k]].n_obs = 0;
    compact_landmarks();
  }
  prior_->clear();
  init_prior_slot_ = -1;
  keyframes_.reset();
}

bool Estimator::triangulate_landmark(Landmark& l, int exclude_slot) {
  Ray rays[2 * capacity::kMaxObservationsPerLandmark];
  int n = 0;
  // Host ray first: the angle test is against it.
  const int ho = l.find_obs(l.host_slot);
  if (ho < 0) return false;
  auto add_ray = [&](int slot, int cam, const Eigen::Vector3f& b) {
    const Eigen::Isometry3d T_w_c = T_w_b(slot) * T_b_c_iso_[cam];
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
  const TriangulationResult r = triangulate(rays, n, options_.min_triangulation_angle_deg * M_PI / 180.0);
  if (!r.ok) return false;
  const Eigen::Vector3d P_c = (T_w_b(l.host_slot) * T_b_c_iso_[l.host_cam]).inverse() * r.p_w;
  const double d = P_c.norm();
  if (P_c.dot(l.b_host) <= 0.0 || d < options_.min_depth_m || d > options_.max_depth_m) return false;
  l.inv_depth = 1.0 / d;
  l.has_depth = true;
  return true;
}

void Estimator::triangulate_all(int exclude_slot) {
  for (int k = 0; k < n_lm_index_; ++k) {
    Landmark& l = landmarks_[lm_index_[k]];
    if (!l.has_depth && !l.outlier) triangulate_landmark(l, exclude_slot);
  }
}

float Estimator::visual_flow_px(int prev_slot, int slot, const Eigen::Vector3d& bg) const {
  // Mean image motion of the left features seen in both frames, with the rotation between them
  // (gyro integrated with bias bg) taken out: translation only. -1 when fewer than 10 features are shared.
  const FrameState& f = slots_[slot];
  Eigen::Matrix3d R_prev_cur = Eigen::Matrix3d::Identity();
  if (f.pre.num_samples() >= 2) {
    const Eigen::Matrix3d R_b_c = T_b_c_iso_[0].linear();
    Eigen::Vector3d alpha, beta;
    Eigen::Quaterniond gamma;
    f.pre.corrected(f.pre.linearization_ba(), bg, &alpha, &beta, &gamma);
    R_prev_cur = R_b_c.transpose() * gamma.toRotationMatrix() * R_b_c;
  }
  double sum = 0.0;
  int n = 0;
  for (int k = 0; k < n_lm_index_; ++k) {
    const Landmark& l = landmarks_[lm_index_[k]];
    const int a = l.find_obs(prev_slot);
    const int b = l.find_obs(slot);
    if (a < 0 || b < 0 || !l.obs[a].has_left || !l.obs[b].has_left) continue;
    const Eigen::Vector3d b_prev = l.obs[a].bearing_left.cast<double>();
    const Eigen::Vector3d b_cur = l.obs[b].bearing_left.cast<double>();
    sum += (R_prev_cur * b_cur - b_prev).norm();
    ++n;
  }
  if (n < 10) return -1.0f;
  return static_cast<float>(sum / n * options_.focal_px);
}

int Estimator::count_depth_observations(int slot, int* n_2d_with_depth) const {
  int n = 0, n2d = 0;
  for (int k = 0; k < n_lm_index_; ++k) {
    const Landmark& l = landmarks_[lm_index_[k]];
    if (!l.has_depth || l.outlier) continue;
    const int o = l.find_obs(slot);
    if (o < 0 || l.host_slot == slot) continue;
    ++n;
    if (!(l.obs[o].has_left && l.obs[o].has_right)) ++n2d;
  }
  if (n_2d_with_depth != nullptr) *n_2d_with_depth = n2d;
  return n;
}

// ---------------------------------------------------------------------------------------------
// Solver

int Estimator::build_problem(const BuildSpec& spec) {
  solver::Problem& P = *problem_;
  P.clear();
  n_visual_ = 0;
  n_selected_ = 0;
  auto note = [&](int id, std::uint8_t kind, int slot) {
    block_kind_[id] = kind;
    block_slot_[id] = static_cast<std::int8_t>(slot);
  };
  for (int k = 0; k < n_; ++k) {
    const int s = order_[k];
    P.add_pose_block(slots_[s].pose, &pose_id_[s]);
    note(pose_id_[s], kKindPose, s);
    P.add_euclidean_block(slots_[s].sb, 9, &sb_id_[s]);
    note(sb_id_[s], kKindSpeedBias, s);
    if (!spec.imu) P.set_constant(sb_id_[s], true);
  }
  for (int c = 0; c < 2; ++c) {
    P.add_pose_block(T_b_c_[c], &ext_id_[c]);
    note(ext_id_[c], kKindExtrinsic, c);
    P.set_constant(ext_id_[c], !options_.estimate_extrinsic);
  }
  if (spec.fix_first_pose && n_ > 0) P.set_constant(pose_id_[order_[0]], true);

  // Landmark selection: depth known, not an outlier, at least two rays, allowed class; 3D first,
  // then the most observed / longest tracked (the paper keeps the best 100-300 features).
  int nc = 0;
  for (int k = 0; k < n_lm_index_; ++k) {
    const int idx = lm_index_[k];
    const Landmark& l = landmarks_[idx];
    if (!l.has_depth || l.outlier) continue;
    const std::uint8_t bit = static_cast<std::uint8_t>(1u << static_cast<int>(l.group()));
    if ((spec.groups & bit) == 0) continue;
    int rays = 0;
    for (int j = 0; j < l.n_obs; ++j) rays += static_cast<int>(l.obs[j].has_left) + static_cast<int>(l.obs[j].has_right);
    if (rays < 2) continue;
    candidates_[nc++] = idx;
  }
  const Landmark* lms = landmarks_.get();
  auto score = [lms](int idx) {
    const Landmark& l = lms[idx];
    return 1000 * l.n_obs + static_cast<int>(std::min<std::uint32_t>(l.track_length, 999));
  };
  // 3D landmarks first, each class best first; when 2D classes are allowed they get a share of
  // the budget (the united features of the paper), 3D fill what 2D cannot.
  int* begin = candidates_.get();
  int* mid = std::partition(begin, begin + nc, [lms](int idx) { return lms[idx].stereo; });
  const int n3 = static_cast<int>(mid - begin), n2 = nc - n3;
  const int budget = options_.max_landmarks_in_solve;
  const int share_2d = static_cast<int>(std::lround(options_.share_2d * budget));
  const int take2 = std::min(n2, std::max(share_2d, budget - n3));
  const int take3 = std::min(n3, budget - take2);
  auto better = [&](int a, int b) { return score(a) > score(b); };
  std::partial_sort(begin, begin + take3, mid, better);
  std::partial_sort(mid, mid + take2, begin + nc, better);
  std::copy(mid, mid + take2, begin + take3);  // chosen: [0, take3 + take2)
  const int keep = take3 + take2;

  const solver::RobustLoss huber = solver::RobustLoss::huber(options_.huber_px / options_.sigma_px);
  for (int c = 0; c < keep; ++c) {
    const int idx = candidates_[c];
    Landmark& l = landmarks_[idx];
    int rays = 0;
    for (int j = 0; j < l.n_obs; ++j) rays += static_cast<int>(l.obs[j].has_left) + static_cast<int>(l.obs[j].has_right);
    if (n_visual_ + rays > kMaxVisualResiduals) {
      ++stats_.drops_residuals;
      break;
    }
    int lm_id = -1;
    P.add_landmark_block(&l.inv_depth, 1, &lm_id);
    note(lm_id, kKindLandmark, -1);
    block_of_landmark_[idx] = lm_id;
    selected_[n_selected_++] = static_cast<std::int16_t>(idx);
    const int h = l.host_slot;
    for (int j = 0; j < l.n_obs; ++j) {
      const LandmarkObservation& o = l.obs[j];
      for (int cam = 0; cam < 2; ++cam) {
        if (!(cam == 0 ? o.has_left : o.has_right)) continue;
        if (o.slot == h && cam == l.host_cam) continue;
        const Eigen::Vector3d b = (cam == 0 ? o.bearing_left : o.bearing_right).cast<double>();
        const double w = cam == 0 ? weight_left_ : weight_right_;
        BearingResidual& r = visual_[n_visual_];
        solver::BlockId ids[5];
        int nb = 0;
        if (o.slot == h) {
          r.set(BearingResidual::Kind::kSameFrame, false, l.b_host, b, w);
          ids[nb++] = ext_id_[l.host_cam];
          ids[nb++] = ext_id_[cam];
        } else {
          const bool same_cam = cam == l.host_cam;
          r.set(BearingResidual::Kind::kTwoFrames, same_cam, l.b_host, b, w);
          r.bind(pose_cache_.get(), h, l.host_cam, o.slot, cam);
          ids[nb++] = pose_id_[h];
          ids[nb++] = pose_id_[o.slot];
          ids[nb++] = ext_id_[l.host_cam];
          if (!same_cam) ids[nb++] = ext_id_[cam];
        }
        ids[nb++] = lm_id;
        if (P.add_residual(&r, huber, ids, nb) != solver::SolverStatus::kOk) {
          ++stats_.drops_residuals;
          continue;
        }
        visual_landmark_[n_visual_] = idx;
        ++n_visual_;
      }
    }
  }
  stats_.peak_residuals = std::max(stats_.peak_residuals, static_cast<std::size_t>(n_visual_));

  if (spec.imu) {
    for (int k = 1; k < n_; ++k) {
      const int si = order_[k - 1], sj = order_[k];
      if (!slots_[sj].imu_ok) continue;
      P.add_residual(&slots_[sj].imu, solver::RobustLoss::trivial(), {pose_id_[si], sb_id_[si], pose_id_[sj], sb_id_[sj]});
    }
    if (init_prior_slot_ >= 0 && position_of(init_prior_slot_) >= 0)
      P.add_residual(&init_prior_, solver::RobustLoss::trivial(), {sb_id_[init_prior_slot_]});
    for (int k = 0; k < n_; ++k) {
      const int s = order_[k];
      if (!slots_[s].still) continue;
      P.add_residual(&zero_velocity_, solver::RobustLoss::trivial(), {sb_id_[s]});
      if (k > 0 && slots_[order_[k - 1]].still)
        P.add_residual(&still_, solver::RobustLoss::trivial(), {pose_id_[order_[k - 1]], pose_id_[s]});
    }
  }
  if (spec.prior && !prior_->empty()) {
    solver::BlockId ids[solver::capacity::kMaxReducedBlocks];
    bool ok = true;
    for (int i = 0; i < prior_->num_blocks() && ok; ++i) {
      const int s = prior_slot_[i];
      switch (prior_kind_[i]) {
        case kKindPose: ok = position_of(s) >= 0; ids[i] = ok ? pose_id_[s] : -1; break;
        case kKindSpeedBias: ok = position_of(s) >= 0; ids[i] = ok ? sb_id_[s] : -1; break;
        default: ids[i] = ext_id_[s]; break;
      }
    }
    if (ok) {
      P.add_prior(prior_.get(), ids);
    } else {
      prior_->clear();  // a frame of the prior left without marginalization: cannot happen
      ++stats_.marginalization_failures;
    }
  }
  return n_selected_;
}

int Estimator::count_candidates(std::uint8_t groups) const {
  int n = 0;
  for (int k = 0; k < n_lm_index_; ++k) {
    const Landmark& l = landmarks_[lm_index_[k]];
    if (!l.has_depth || l.outlier) continue;
    if ((groups & static_cast<std::uint8_t>(1u << static_cast<int>(l.group()))) == 0) continue;
    int rays = 0;
    for (int j = 0; j < l.n_obs; ++j) rays += static_cast<int>(l.obs[j].has_left) + static_cast<int>(l.obs[j].has_right);
    n += rays >= 2 ? 1 : 0;
  }
  return n;
}

bool Estimator::solve(const BuildSpec& spec, int max_iterations, double max_time_s, bool* converged) {
  build_problem(spec);
  solver::SolverOptions opt;
  opt.max_iterations = max_iterations;
  opt.max_time_s = max_time_s;
  opt.function_tolerance = options_.function_tolerance;
  solver::SolverSummary summary;
  const solver::SolverStatus st = problem_->solve(opt, &summary);
  ++stats_.solves;
  if (converged != nullptr) *converged = st == solver::SolverStatus::kConverged;
  return solver::usable(st);
}

int Estimator::mark_outliers() {
  // A landmark with any observation farther than outlier_px from its prediction is dropped (it
  // leaves the map; the front end keeps tracking it and it comes back as a new landmark).
  const double limit_rad = options_.outlier_px / options_.focal_px;
  pose_cache_->invalidate();  // evaluated outside a solve: the window may have moved since
  int marked = 0;
  for (int i = 0; i < n_selected_; ++i) {
    Landmark& l = landmarks_[selected_[i]];
    if (!(l.inv_depth > 1.0 / options_.max_depth_m && l.inv_depth < 1.0 / options_.min_depth_m)) {
      l.has_depth = false;  // re-triangulated later
      continue;
    }
    const int h = l.host_slot;
    bool bad = false;
    for (int j = 0; j < l.n_obs && !bad; ++j) {
      const LandmarkObservation& o = l.obs[j];
      for (int cam = 0; cam < 2 && !bad; ++cam) {
        if (!(cam == 0 ? o.has_left : o.has_right)) continue;
        if (o.slot == h && cam == l.host_cam) continue;
        const Eigen::Vector3d b = (cam == 0 ? o.bearing_left : o.bearing_right).cast<double>();
        BearingResidual r;
        const double* params[5];
        int nb = 0;
        if (o.slot == h) {
          r.set(BearingResidual::Kind::kSameFrame, false, l.b_host, b, 1.0);
          params[nb++] = T_b_c_[l.host_cam];
          params[nb++] = T_b_c_[cam];
        } else {
          const bool same_cam = cam == l.host_cam;
          r.set(BearingResidual::Kind::kTwoFrames, same_cam, l.b_host, b, 1.0);
          r.bind(pose_cache_.get(), h, l.host_cam, o.slot, cam);
          params[nb++] = slots_[h].pose;
          params[nb++] = slots_[o.slot].pose;
          params[nb++] = T_b_c_[l.host_cam];
          if (!same_cam) params[nb++] = T_b_c_[cam];
        }
        params[nb++] = &l.inv_depth;
        double e = 0.0;
        if (!r.error_rad(params, &e) || e > limit_rad) bad = true;
      }
    }
    if (bad) {
      l.outlier = true;
      ++marked;
    }
  }
  stats_.outlier_landmarks += static_cast<std::uint64_t>(marked);
  return marked;
}

void Estimator::save_state(Backup* b) const {
  for (int s = 0; s < kSlots; ++s) {
    std::copy(slots_[s].pose, slots_[s].pose + 7, b->pose[s]);
    std::copy(slots_[s].sb, slots_[s].sb + 9, b->sb[s]);
  }
  for (int i = 0; i < kMaxLandmarks; ++i) {
    b->inv_depth[i] = landmarks_[i].inv_depth;
    b->has_depth[i] = landmarks_[i].has_depth;
  }
}

void Estimator::restore_state(const Backup& b) {
  for (int s = 0; s < kSlots; ++s) {
    std::copy(b.pose[s], b.pose[s] + 7, slots_[s].pose);
    std::copy(b.sb[s], b.sb[s] + 9, slots_[s].sb);
  }
  for (int i = 0; i < kMaxLandmarks; ++i) {
    landmarks_[i].inv_depth = b.inv_depth[i];
    landmarks_[i].has_depth = b.has_depth[i];
  }
}

void Estimator::rotate_world(const Eigen::Matrix3d& R, const Eigen::Vector3d& pivot) {
  const Eigen::Quaterniond q(R);
  for (int k = 0; k < n_; ++k) {
    FrameState& f = frame_at(k);
    Eigen::Map<Eigen::Vector3d> p(f.pose);
    p = pivot + R * (p - pivot);
    set_quat(f.pose, q * quat_of(f.pose));
    Eigen::Map<Eigen::Vector3d> v(f.sb);
    v = R * v;
  }
}

void Estimator::update_imu_factors() {
  for (int k = 1; k < n_; ++k) {
    FrameState& f = frame_at(k);
    if (f.pre.num_samples() < 2) {
      f.imu_ok = false;
      continue;
    }
    const Eigen::Map<const Eigen::Vector3d> ba(frame_at(k - 1).sb + 3), bg(frame_at(k - 1).sb + 6);
    f.pre.repropagate_if_needed(ba, bg);
    f.imu_ok = f.imu.residual().init(&f.pre, g_w_) == Status::kOk;
  }
}

// ---------------------------------------------------------------------------------------------
// Marginalization (paper Sec. III-C): the oldest frame and the landmarks it hosts go into the
// prior when the newest frame is a keyframe; otherwise the second newest frame is dropped (its
// IMU interval merged into the newest one's) and only removed from the prior if the prior
// holds it.

bool Estimator::marginalize_oldest() {
  const int s0 = order_[0];
  solver::BlockId ids[2 + capacity::kMaxLandmarks];
  int n = 0;
  ids[n++] = pose_id_[s0];
  ids[n++] = sb_id_[s0];
  for (int i = 0; i < n_selected_; ++i) {
    const Landmark& l = landmarks_[selected_[i]];
    if (l.find_obs(s0) >= 0) ids[n++] = block_of_landmark_[selected_[i]];
  }
  return adopt_marginalization(*problem_, ids, n);
}

bool Estimator::adopt_marginalization(solver::Problem& problem, const int* ids, int n) {
  const solver::SolverStatus st = problem.marginalize(ids, n, prior_next_.get());
  if (st != solver::SolverStatus::kOk) {
    // The information is lost, the window goes on: counted, never fatal.
    ++stats_.marginalization_failures;
    prior_->clear();
    return false;
  }
  // The prior's blocks are named by this problem's ids: keep what they are (kind, frame slot).
  for (int i = 0; i < prior_next_->num_blocks(); ++i) {
    const int id = prior_next_->block(i).source_id;
    prior_kind_[i] = block_kind_[id];
    prior_slot_[i] = block_slot_[id];
  }
  std::swap(prior_, prior_next_);
  return true;
}

bool Estimator::marginalize_prior_blocks(int slot) {
  // Only the prior touches the dropped frame here: a problem of the prior alone.
  bool touches = false;
  for (int i = 0; i < prior_->num_blocks(); ++i)
    touches = touches || ((prior_kind_[i] == kKindPose || prior_kind_[i] == kKindSpeedBias) && prior_slot_[i] == slot);
  if (!touches) return true;
  solver::Problem& P = *problem_;
  P.clear();
  solver::BlockId ids[solver::capacity::kMaxReducedBlocks];
  for (int i = 0; i < prior_->num_blocks(); ++i) {
    const int s = prior_slot_[i];
    double* x = prior_kind_[i] == kKindPose ? slots_[s].pose : prior_kind_[i] == kKindSpeedBias ? slots_[s].sb : T_b_c_[s];
    if (prior_kind_[i] == kKindSpeedBias) {
      P.add_euclidean_block(x, 9, &ids[i]);
    } else {
      P.add_pose_block(x, &ids[i]);
    }
    block_kind_[ids[i]] = prior_kind_[i];
    block_slot_[ids[i]] = static_cast<std::int8_t>(s);
  }
  P.add_prior(prior_.get(), ids);
  solver::BlockId marg[2];
  int n = 0;
  for (int i = 0; i < prior_->num_blocks(); ++i)
    if ((prior_kind_[i] == kKindPose || prior_kind_[i] == kKindSpeedBias) && prior_slot_[i] == slot) marg[n++] = ids[i];
  return adopt_marginalization(P, marg, n);
}

void Estimator::slide_window(EstimatorTiming* timing) {
  if (n_ < options_.window_size) return;
  const auto t0 = std::chrono::steady_clock::now();
  FrameState& newest = frame_at(n_ - 1);
  if (newest.keyframe) {
    if (mode_ == EstimatorMode::kVio) marginalize_oldest();
    remove_slot(0);
    ++stats_.marginalized_old;
  } else {
    const int pos = n_ - 2;
    const int s = order_[pos];
    if (mode_ == EstimatorMode::kVio) marginalize_prior_blocks(s);
    // Merge the IMU intervals: newest.pre = pre(s) followed by pre(newest).
    FrameState& second = slots_[s];
    const std::size_t m = newest.pre.num_samples();
    for (std::size_t k = 0; k < m; ++k) scratch_samples_[k] = newest.pre.sample(k);
    if (second.pre.num_samples() >= 1 && m >= 1) {
      const Eigen::Vector3d ba = second.pre.linearization_ba(), bg = second.pre.linearization_bg();
      newest.pre.reset(second.pre.sample(0), ba, bg);
      for (std::size_t k = 1; k < second.pre.num_samples(); ++k)
        if (newest.pre.add(second.pre.sample(k)) == Status::kFull) ++stats_.drops_imu;
      for (std::size_t k = 1; k < m; ++k)
        if (newest.pre.add(scratch_samples_[k]) == Status::kFull) ++stats_.drops_imu;
      newest.imu_ok = second.imu_ok && newest.imu_ok && newest.imu.residual().init(&newest.pre, g_w_) == Status::kOk;
    } else {
      newest.imu_ok = false;
    }
    newest.still = newest.still && second.still;
    remove_slot(pos);
    ++stats_.marginalized_second_new;
  }
  if (timing != nullptr) timing->marginalize_ms += static_cast<float>(ms_since(t0));
}

// ---------------------------------------------------------------------------------------------
// Modes

void Estimator::set_mode(EstimatorMode to, const char* reason) {
  if (to == mode_) return;
  ModeChange c;
  c.t_ns = last_output_.t_ns;
  c.from = mode_;
  c.to = to;
  c.reason = reason;
  if (stats_.mode_changes.push_back(c) != Status::kOk) ++stats_.mode_changes_dropped;
  mode_ = to;
  if (to == EstimatorMode::kVio && !stats_.initialized) {
    stats_.initialized = true;
    stats_.init_t_ns = c.t_ns;
    stats_.init_case = reason;
  }
}

void Estimator::set_nav_from(const FrameState& f) {
  NavState s;
  s.t_ns = f.t_ns;
  s.p_w_b = Eigen::Vector3d(f.pose[0], f.pose[1], f.pose[2]);
  s.q_w_b = quat_of(f.pose).normalized();
  s.v_w_b = Eigen::Vector3d(f.sb[0], f.sb[1], f.sb[2]);
  s.ba = Eigen::Vector3d(f.sb[3], f.sb[4], f.sb[5]);
  s.bg = Eigen::Vector3d(f.sb[6], f.sb[7], f.sb[8]);
  ImuSample boundary = last_imu_;
  if (boundary.t_ns < f.t_ns) boundary.t_ns = f.t_ns;
  if (have_imu_) nav_.reset(s, boundary);
}

bool Estimator::track_pnp(FrameState& f, const Eigen::Isometry3d& prior) {
  const int slot = static_cast<int>(&f - slots_.get());
  int n = 0;
  for (int k = 0; k < n_lm_index_; ++k) {
    const int idx = lm_index_[k];
    const Landmark& l = landmarks_[idx];
    if (!l.has_depth || l.outlier || l.host_slot == slot) continue;
    const int o = l.find_obs(slot);
    if (o < 0) continue;
    PnpMatch& m = pnp_matches_[n];
    m.p_w = T_w_b(l.host_slot) * (T_b_c_iso_[l.host_cam] * (l.b_host / l.inv_depth));
    m.cam = l.obs[o].has_left ? 0 : 1;
    m.bearing = (m.cam == 0 ? l.obs[o].bearing_left : l.obs[o].bearing_right).cast<double>().normalized();
    pnp_landmark_[n] = static_cast<std::int16_t>(idx);
    ++n;
  }
  if (n < options_.min_init_3d) return false;
  PnpOptions po;
  po.min_inliers = options_.min_init_3d;
  po.inlier_rad = options_.outlier_px / options_.focal_px;
  Eigen::Isometry3d T = prior;
  const PnpResult r = solve_pnp(pnp_matches_.get(), n, T_b_c_iso_, po, &T, pnp_mask_.get());
  if (!r.ok) return false;
  pose_from_iso(T, f.pose);
  for (int k = 0; k < n; ++k)
    if (pnp_mask_[k] == 0) landmarks_[pnp_landmark_[k]].outlier = true;
  return true;
}

bool Estimator::visual_bundle_adjustment(int iterations) {
  BuildSpec spec;
  spec.groups = kAllGroups;
  spec.imu = false;
  spec.prior = false;
  spec.fix_first_pose = true;
  const bool ok = solve(spec, iterations, 1e9);
  if (mark_outliers() > 0) compact_landmarks();
  return ok;
}

bool Estimator::static_alignment() {
  // At rest the accelerometer measures gravity and the gyro its bias: no motion needed.
  FrameState& newest = frame_at(n_ - 1);
  const Eigen::Vector3d f_b = last_still_.mean_accel_m_s2;
  const Eigen::Vector3d up_w = quat_of(newest.pose).normalized() * f_b;
  rotate_world(rotation_between(up_w, Eigen::Vector3d::UnitZ()), Eigen::Map<const Eigen::Vector3d>(newest.pose));
  const Eigen::Vector3d bg = last_still_.mean_gyro_rad_s;
  for (int k = 0; k < n_; ++k) {
    FrameState& f = frame_at(k);
    Eigen::Map<Eigen::Matrix<double, 9, 1>> sb(f.sb);
    sb.setZero();
    sb.tail<3>() = bg;
    if (k > 0 && f.pre.num_samples() >= 2) f.pre.repropagate(Eigen::Vector3d::Zero(), bg);
  }
  update_imu_factors();
  SpeedBiasPrior::Vector9 target = SpeedBiasPrior::Vector9::Zero();
  target.tail<3>() = bg;
  SpeedBiasPrior::Vector9 sigma;
  sigma << 0.0, 0.0, 0.0, options_.init_bias_sigma_ba, options_.init_bias_sigma_ba, options_.init_bias_sigma_ba,
      options_.init_bias_sigma_bg, options_.init_bias_sigma_bg, options_.init_bias_sigma_bg;
  init_prior_.set(target, sigma);
  init_prior_slot_ = order_[0];
  prior_->clear();
  set_mode(EstimatorMode::kVio, "standstill");
  return true;
}

bool Estimator::try_alignment(FrameState& newest) {
  ++stats_.align_attempts;
  frames_since_align_ = 0;
  Eigen::Quaterniond q[capacity::kWindowSize];
  Eigen::Vector3d p[capacity::kWindowSize];
  const Preintegration* pre[capacity::kWindowSize];
  for (int k = 0; k < n_; ++k) {
    FrameState& f = frame_at(k);
    q[k] = quat_of(f.pose).normalized();
    p[k] = Eigen::Map<const Eigen::Vector3d>(f.pose);
    pre[k] = k > 0 && f.pre.num_samples() >= 2 ? &f.pre : nullptr;
  }
  save_state(backup_b_.get());  // the VO state, restored on failure
  auto fail = [&](bool disagreement) {
    restore_state(*backup_b_);
    init_prior_slot_ = -1;
    prior_->clear();
    ++stats_.align_failures;
    if (disagreement) ++stats_.align_disagreements;
    return false;
  };
  // Step 1: IMU initialization.
  Eigen::Vector3d bg = Eigen::Vector3d::Zero();
  if (estimate_gyro_bias(q, pre, n_, &bg) != Status::kOk || bg.norm() > 0.5) return fail(false);
  for (int k = 1; k < n_; ++k)
    if (pre[k] != nullptr) frame_at(k).pre.repropagate(Eigen::Vector3d::Zero(), bg);
  GravityVelocity gv;
  if (estimate_gravity_velocity(p, q, pre, n_, Eigen::Vector3d::Zero(), bg, &gv) != Status::kOk) return fail(false);
  if (std::abs(gv.g_w.norm() - options_.gravity_m_s2) > options_.max_gravity_error_m_s2) return fail(false);
  const Eigen::Matrix3d R_fix = rotation_between(gv.g_w, -Eigen::Vector3d::UnitZ());
  for (int k = 0; k < n_; ++k) {
    FrameState& f = frame_at(k);
    Eigen::Map<Eigen::Matrix<double, 9, 1>> sb(f.sb);
    sb.head<3>() = gv.v_w[k];
    sb.segment<3>(3).setZero();
    sb.tail<3>() = bg;
  }
  const Eigen::Vector3d pivot = Eigen::Map<const Eigen::Vector3d>(newest.pose);
  rotate_world(R_fix, pivot);
  update_imu_factors();
  // Step 2: the loosely coupled BA, twice; the accelerometer bias is left free so that an
  // unobservable tilt shows up as a disagreement instead of being pulled back by a prior.
  SpeedBiasPrior::Vector9 target = SpeedBiasPrior::Vector9::Zero();
  target.tail<3>() = bg;
  SpeedBiasPrior::Vector9 sigma = SpeedBiasPrior::Vector9::Zero();
  sigma.tail<3>().setConstant(options_.init_bias_sigma_bg);
  init_prior_.set(target, sigma);
  init_prior_slot_ = order_[0];
  prior_->clear();
  save_state(backup_a_.get());
  BuildSpec spec;
  spec.groups = kAllGroups;
  spec.imu = true;
  spec.prior = false;
  constexpr int kAlignIterations = 8;
  const Eigen::Matrix3d R_perturb =
      Eigen::AngleAxisd(options_.align_perturb_deg * M_PI / 180.0, Eigen::Vector3d::UnitX()).toRotationMatrix();
  rotate_world(R_perturb, pivot);
  if (!solve(spec, kAlignIterations, 1e9)) return fail(false);
  const FrameState& f0 = frame_at(0);
  const Eigen::Vector3d up2 = quat_of(f0.pose).normalized().conjugate() * Eigen::Vector3d::UnitZ();
  const Eigen::Vector3d ba2(f0.sb[3], f0.sb[4], f0.sb[5]);
  restore_state(*backup_a_);
  if (!solve(spec, kAlignIterations, 1e9)) return fail(false);
  const Eigen::Vector3d up1 = quat_of(f0.pose).normalized().conjugate() * Eigen::Vector3d::UnitZ();
  const Eigen::Vector3d ba1(f0.sb[3], f0.sb[4], f0.sb[5]);
  const double tilt_deg = std::acos(std::min(1.0, up1.dot(up2))) * 180.0 / M_PI;
  if (tilt_deg > options_.align_agree_deg || (ba1 - ba2).norm() > options_.align_agree_ba_m_s2) return fail(true);
  for (int k = 0; k < n_; ++k)
    if (!Eigen::Map<const Eigen::Matrix<double, 9, 1>>(frame_at(k).sb).allFinite()) return fail(false);
  // Accepted: from now on the bias prior also holds the accelerometer bias near the solution.
  sigma.segment<3>(3).setConstant(options_.init_bias_sigma_ba);
  target.segment<3>(3) = ba1;
  init_prior_.set(target, sigma);
  if (mark_outliers() > 0) compact_landmarks();
  set_mode(EstimatorMode::kVio, "visual-imu alignment");
  return true;
}

void Estimator::frame_imu_only(FrameState& f) {
  // Case 1: the pose is the IMU's; keep trying the stereo visual initialization.
  if (n_ < 2) {
    triangulate_all(-1);
    return;
  }
  Eigen::Isometry3d prior = iso_from_pose(f.pose);
  if (!track_pnp(f, prior)) {
    ++stats_.visual_init_failures;
    reset_window(true);
    triangulate_all(-1);
    return;
  }
  triangulate_all(-1);
  visual_bundle_adjustment(6);
  set_nav_from(f);
  if (f.still && last_still_valid_) {
    static_alignment();
    return;
  }
  set_mode(EstimatorMode::kVo, "visual init");
  frames_since_align_ = options_.align_retry_frames;  // try at once when the window allows
}

void Estimator::frame_vo(FrameState& f) {
  const FrameState& prev = frame_at(n_ - 2);
  const double dt = static_cast<double>(f.t_ns - prev.t_ns) * 1e-9;
  Eigen::Isometry3d prior = iso_from_pose(prev.pose);
  prior.translation() += vo_velocity_ * dt;
  if (f.imu_ok) {
    Eigen::Vector3d alpha, beta;
    Eigen::Quaterniond gamma;
    f.pre.corrected(Eigen::Map<const Eigen::Vector3d>(prev.sb + 3), Eigen::Map<const Eigen::Vector3d>(prev.sb + 6),
                    &alpha, &beta, &gamma);
    prior.linear() = prior.linear() * gamma.toRotationMatrix();
  }
  pose_from_iso(prior, f.pose);
  if (!track_pnp(f, prior)) {
    ++stats_.resets;
    set_mode(EstimatorMode::kImuOnly, "vision lost in VO");
    set_nav_from(f);
    reset_window(true);
    triangulate_all(-1);
    return;
  }
  triangulate_all(-1);
  // Round 1, then round 2 on the cleaned set when something was removed or round 1 was cut short.
  BuildSpec spec;
  spec.groups = kAllGroups;
  spec.imu = false;
  spec.prior = false;
  spec.fix_first_pose = true;
  bool converged = false;
  solve(spec, options_.max_iterations_stage, 1e9, &converged);
  const int outliers = mark_outliers();
  if (outliers > 0) compact_landmarks();
  if (outliers > 0 || !converged) {
    solve(spec, std::max(1, options_.max_iterations_round2), options_.round2_time_s);
    ++stats_.second_rounds;
  }
  const FrameState& prev2 = frame_at(n_ - 2);
  if (dt > 0.0) vo_velocity_ = (Eigen::Map<const Eigen::Vector3d>(f.pose) - Eigen::Map<const Eigen::Vector3d>(prev2.pose)) / dt;
  Eigen::Map<Eigen::Vector3d>(f.sb) = vo_velocity_;
  ++frames_since_align_;
  if (f.still && prev.still && last_still_valid_) {
    static_alignment();
    return;
  }
  const double span_s = static_cast<double>(f.t_ns - frame_at(0).t_ns) * 1e-9;
  if (n_ >= options_.min_align_frames && span_s >= options_.min_align_span_s &&
      frames_since_align_ >= options_.align_retry_frames) {
    try_alignment(f);
  }
}

void Estimator::frame_vio(FrameState& f, EstimatorTiming* timing) {
  triangulate_all(static_cast<int>(&f - slots_.get()));
  update_imu_factors();
  const auto t1 = std::chrono::steady_clock::now();
  BuildSpec spec;
  spec.imu = true;
  spec.prior = true;
  const int n3d = count_candidates(k3DGroup);
  const int it = options_.max_iterations_stage;
  bool converged = false;
  if (!options_.two_stage) {
    spec.groups = kAllGroups;
    solve(spec, it, 1e9, &converged);
  } else if (n3d < options_.min_3d_landmarks) {
    spec.groups = kAllGroups;
    solve(spec, it, 1e9, &converged);
    ++stats_.stage_added_2d_right;
  } else if (count_candidates(k2DLeftGroup) == 0) {
    // No 2D-left landmark to add: the second stage would be the first again.
    spec.groups = k3DGroup;
    solve(spec, it, 1e9, &converged);
    ++stats_.stage_3d_sufficient;
  } else {
    // The paper's two stages: stereo alone and stereo + 2D-left from the same start; agreement
    // keeps the latter, disagreement brings in the 2D-right features as well.
    save_state(backup_a_.get());
    spec.groups = k3DGroup;
    solve(spec, options_.max_iterations_stage_a, 1e9);
    const Eigen::Vector3d p_a = Eigen::Map<const Eigen::Vector3d>(f.pose);
    const Eigen::Quaterniond q_a = quat_of(f.pose).normalized();
    restore_state(*backup_a_);
    spec.groups = k3DGroup | k2DLeftGroup;
    solve(spec, it, 1e9, &converged);
    const double dp = (Eigen::Map<const Eigen::Vector3d>(f.pose) - p_a).norm();
    const double dq_deg = q_a.angularDistance(quat_of(f.pose).normalized()) * 180.0 / M_PI;
    if (dp <= options_.stage_agree_m && dq_deg <= options_.stage_agree_deg) {
      ++stats_.stage_kept_2d_left;
    } else {
      restore_state(*backup_a_);
      spec.groups = kAllGroups;
      solve(spec, it, 1e9, &converged);
      ++stats_.stage_added_2d_right;
    }
  }
  if (timing != nullptr) timing->solve_round1_ms = static_cast<float>(ms_since(t1));
  const auto t2 = std::chrono::steady_clock::now();
  // Second round (paper Sec. III-C): after removing outliers, bounded by time; nothing to refine
  // when round 1 converged on a set without outliers.
  const int outliers = mark_outliers();
  if (outliers > 0) compact_landmarks();
  if (outliers > 0 || !converged) {
    solve(spec, std::max(1, options_.max_iterations_round2), options_.round2_time_s);
    ++stats_.second_rounds;
  }
  if (timing != nullptr) timing->solve_round2_ms = static_cast<float>(ms_since(t2));
}

void Estimator::add_frame(const FrameFeatures& ff, EstimatorOutput* out, EstimatorTiming* timing) {
  const auto t0 = std::chrono::steady_clock::now();
  EstimatorTiming local_timing;
  if (timing == nullptr) timing = &local_timing;
  *timing = EstimatorTiming{};
  if (stats_.frames > 0 && ff.t_ns <= last_output_.t_ns) {
    // A source bug (sources order and de-duplicate): counted, never processed.
    ++stats_.frames_out_of_order;
    if (out != nullptr) {
      *out = last_output_;
      out->valid = false;
    }
    return;
  }
  ++stats_.frames;
  if (stats_.first_frame_t_ns < 0) stats_.first_frame_t_ns = ff.t_ns;
  const std::int64_t td_ns = static_cast<std::int64_t>(std::llround(rig_.td_s * 1e9));
  const int slot = next_slot_;
  FrameState& f = slots_[slot];
  f.t_ns = ff.t_ns + td_ns;
  f.keyframe = false;
  close_interval(f);
  StandstillResult sr;
  f.still = check_standstill(f.t_ns, &sr);
  last_still_ = sr;
  last_still_valid_ = f.still;
  timing->preintegrate_ms = static_cast<float>(ms_since(t0));
  last_output_.t_ns = ff.t_ns;

  // Initial state of the new frame.
  if (mode_ == EstimatorMode::kImuOnly || n_ == 0) {
    if (f.still && mode_ == EstimatorMode::kImuOnly) {
      velocity_known_ = true;
      // Hold still when still: zero velocity, gyro bias from the rest, attitude re-levelled.
      NavState s = nav_.state();
      const Eigen::Vector3d up_w = s.q_w_b * sr.mean_accel_m_s2;
      s.q_w_b = Eigen::Quaterniond(rotation_between(up_w, Eigen::Vector3d::UnitZ())) * s.q_w_b;
      s.v_w_b.setZero();
      s.bg = sr.mean_gyro_rad_s;
      ImuSample b = last_imu_;
      nav_.reset(s, b);
    }
    const NavState& s = nav_.state();
    f.pose[0] = s.p_w_b.x();
    f.pose[1] = s.p_w_b.y();
    f.pose[2] = s.p_w_b.z();
    set_quat(f.pose, s.q_w_b);
    Eigen::Map<Eigen::Vector3d>(f.sb) = s.v_w_b;
    Eigen::Map<Eigen::Vector3d>(f.sb + 3) = s.ba;
    Eigen::Map<Eigen::Vector3d>(f.sb + 6) = s.bg;
  } else {
    const FrameState& prev = frame_at(n_ - 1);
    std::copy(prev.sb, prev.sb + 9, f.sb);
    if (mode_ == EstimatorMode::kVio && f.imu_ok) {
      NavState si;
      si.p_w_b = Eigen::Map<const Eigen::Vector3d>(prev.pose);
      si.q_w_b = quat_of(prev.pose).normalized();
      si.v_w_b = Eigen::Map<const Eigen::Vector3d>(prev.sb);
      si.ba = Eigen::Map<const Eigen::Vector3d>(prev.sb + 3);
      si.bg = Eigen::Map<const Eigen::Vector3d>(prev.sb + 6);
      const NavState sj = predict(si, f.pre, g_w_);
      Eigen::Map<Eigen::Vector3d>(f.pose) = sj.p_w_b;
      set_quat(f.pose, sj.q_w_b);
      Eigen::Map<Eigen::Vector3d>(f.sb) = sj.v_w_b;
    } else {
      std::copy(prev.pose, prev.pose + 7, f.pose);
    }
  }
  order_[n_++] = slot;
  ingest(ff, slot);
  // The IMU alone cannot tell rest from uniform motion (both read gravity and no rotation): when
  // the images can tell, they must agree that nothing moves.
  if (f.still && n_ >= 2) {
    const float flow_px = visual_flow_px(order_[n_ - 2], slot, sr.mean_gyro_rad_s);
      if (flow_px > static_cast<float>(options_.still_max_flow_px)) {
      f.still = false;
      last_still_valid_ = false;
      ++stats_.still_rejected_by_vision;
    }
  }
  if (f.still) ++stats_.still_frames;
  int n2d = 0;
  count_depth_observations(slot, &n2d);
  f.keyframe = keyframes_.update(ff, n2d).is_keyframe;

  switch (mode_) {
    case EstimatorMode::kImuOnly: frame_imu_only(f); break;
    case EstimatorMode::kVo: frame_vo(f); break;
    case EstimatorMode::kVio: frame_vio(f, timing); break;
  }

  if (mode_ == EstimatorMode::kVio) {
    const Eigen::Map<const Eigen::Matrix<double, 16, 1>> all(f.pose);  // pose (7) and sb (9) are adjacent
    (void)all;
    const Eigen::Map<const Eigen::Vector3d> v(f.sb);
    bool finite = v.allFinite();
    for (double x : f.pose) finite = finite && std::isfinite(x);
    if (!finite || v.norm() > options_.max_speed_m_s) {
      // Divergence: back to the last good pose, IMU only, and start again.
      ++stats_.resets;
      Eigen::Map<Eigen::Vector3d>(f.pose) = last_output_.p_w_b;
      set_quat(f.pose, last_output_.q_w_b);
      Eigen::Map<Eigen::Matrix<double, 9, 1>>(f.sb).setZero();
      Eigen::Map<Eigen::Vector3d>(f.sb + 3) = last_output_.ba;
      Eigen::Map<Eigen::Vector3d>(f.sb + 6) = last_output_.bg;
      set_mode(EstimatorMode::kImuOnly, "divergence");
      reset_window(true);
    }
  }
  if (mode_ != EstimatorMode::kImuOnly || n_ > 0) set_nav_from(frame_at(n_ - 1));

  // Output of this frame (before the window slides: the newest frame stays anyway).
  EstimatorOutput& o = last_output_;
  o.t_ns = ff.t_ns;
  o.mode = mode_;
  // IMU_ONLY gives a pose only from a known state: at rest (zero velocity) or the last VO/VIO
  // estimate. Started in motion without vision, the velocity is unknown and the propagated
  // position would drift by metres within seconds: no pose rather than a false one.
  if (mode_ != EstimatorMode::kImuOnly) velocity_known_ = true;
  o.valid = mode_ != EstimatorMode::kImuOnly || (attitude_known_ && velocity_known_);
  if (!o.valid) ++stats_.frames_without_pose;
  o.keyframe = f.keyframe;
  o.p_w_b = Eigen::Map<const Eigen::Vector3d>(f.pose);
  o.q_w_b = quat_of(f.pose).normalized();
  o.v_w_b = Eigen::Map<const Eigen::Vector3d>(f.sb);
  o.ba = Eigen::Map<const Eigen::Vector3d>(f.sb + 3);
  o.bg = Eigen::Map<const Eigen::Vector3d>(f.sb + 6);
  o.still = f.still;
  o.landmarks_in_solve = mode_ == EstimatorMode::kImuOnly ? 0 : n_selected_;
  o.n_3d_used = o.n_2d_left_used = o.n_2d_right_used = 0;
  if (mode_ != EstimatorMode::kImuOnly) {
    for (int i = 0; i < n_selected_; ++i) {
      switch (landmarks_[selected_[i]].group()) {
        case LandmarkGroup::k3D: ++o.n_3d_used; break;
        case LandmarkGroup::k2DLeft: ++o.n_2d_left_used; break;
        case LandmarkGroup::k2DRight: ++o.n_2d_right_used; break;
      }
    }
    stats_.sum_landmarks_in_solve += n_selected_;
    stats_.sum_2d_in_solve += o.n_2d_left_used + o.n_2d_right_used;
    ++stats_.frames_solved;
  }
  if (out != nullptr) *out = o;

  slide_window(timing);
  compact_landmarks();
  // The next interval starts at this frame.
  int free_slot = -1;
  for (int s = 0; s < kSlots && free_slot < 0; ++s)
    if (position_of(s) < 0) free_slot = s;
  next_slot_ = free_slot;
  FrameState& next = slots_[next_slot_];
  next_pre_started_ = false;
  if (have_imu_) {
    ImuSample boundary = last_imu_;
    boundary.t_ns = std::max(boundary.t_ns, f.t_ns);
    next_pre_started_ = next.pre.reset(boundary, o.ba, o.bg) == Status::kOk;
  }
  ++stats_.frames_in_mode[static_cast<int>(mode_)];
  timing->backend_ms = static_cast<float>(ms_since(t0));
}

}  // namespace ums
