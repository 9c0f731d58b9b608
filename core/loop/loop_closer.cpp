#include "core/loop/loop_closer.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <stdexcept>
#include <string>

#include "core/math/quaternion.hpp"

namespace ums::loop {

namespace {

constexpr double kDegPerRad = 180.0 / M_PI;

double angle_deg(const Eigen::Matrix3d& R) {
  return Eigen::AngleAxisd(R).angle() * kDegPerRad;
}

std::uint32_t hash_calibration(const RigCalibration& rig) {
  std::uint32_t crc = 0;
  for (const CameraCalibration& c : rig.cam) {
    std::int64_t v[3 + 8 + 12] = {static_cast<std::int64_t>(c.model), c.width, c.height};
    const double d[] = {c.fx, c.fy, c.cx, c.cy, c.distortion[0], c.distortion[1], c.distortion[2], c.distortion[3]};
    int n = 3;
    for (double x : d) v[n++] = std::llround(x * 1e6);
    // The camera in the IMU frame (the keyframes' body): exactly T_b_c while T_b_i is identity.
    const Eigen::Matrix4d T_i_c = (rig.imu.T_b_i.inverse() * c.T_b_c).matrix();
    for (int r = 0; r < 3; ++r)
      for (int k = 0; k < 4; ++k) v[n++] = std::llround(T_i_c(r, k) * 1e6);
    crc = crc32(reinterpret_cast<const std::uint8_t*>(v), sizeof(std::int64_t) * static_cast<std::size_t>(n), crc);
  }
  return crc;
}

}  // namespace

// One keyframe's left-feature descriptors, waiting for the keyframe to leave the window.
struct LoopCloser::Pending {
  FrameId id = kNoFrame;
  int n = 0;
  std::uint32_t feature_id[capacity::kMaxFeaturesPerCamera];  // ascending
  Descriptor descriptor[capacity::kMaxFeaturesPerCamera];
};

const char* to_string(LoopGate g) {
  switch (g) {
    case LoopGate::kScore: return "score";
    case LoopGate::kMatches: return "matches";
    case LoopGate::kInliers: return "inliers";
    case LoopGate::kInlierRatio: return "inlier_ratio";
    case LoopGate::kGravity: return "gravity";
    case LoopGate::kDriftBudget: return "drift_budget";
    case LoopGate::kPoseGraph: return "pose_graph";
    case LoopGate::kCount: break;
  }
  return "unknown";
}

void LoopOptions::validate() const {
  auto need = [](bool ok, const char* field, double value) {
    if (!ok) throw std::invalid_argument(std::string("loop.") + field + ": invalid value " + std::to_string(value));
  };
  need(recent_s >= 0.0, "recent_s", recent_s);
  need(candidates >= 1 && candidates <= 16, "candidates", candidates);
  need(min_features >= 8 && min_features <= static_cast<int>(capacity::kMaxLoopFeaturesPerKeyframe), "min_features", min_features);
  need(min_inliers >= 8, "min_inliers", min_inliers);
  need(min_inlier_ratio >= 0.0 && min_inlier_ratio <= 1.0, "min_inlier_ratio", min_inlier_ratio);
  need(max_gravity_deg > 0.0, "max_gravity_deg", max_gravity_deg);
  need(drift_base_m > 0.0 && drift_per_m >= 0.0, "drift_base_m", drift_base_m);
  need(drift_base_deg > 0.0 && drift_per_m_deg >= 0.0, "drift_base_deg", drift_base_deg);
  need(protected_recent >= 1 && protected_recent < static_cast<int>(capacity::kMaxKeyframes) / 2,
       "protected_recent", protected_recent);
  need(odom_sigma_p_m > 0.0 && odom_sigma_p_per_m >= 0.0, "odom_sigma_p_m", odom_sigma_p_m);
  need(odom_sigma_yaw_deg > 0.0 && odom_sigma_yaw_deg_per_m >= 0.0, "odom_sigma_yaw_deg", odom_sigma_yaw_deg);
  need(loop_interval_s >= 0.0, "loop_interval_s", loop_interval_s);
  need(blind_sigma_scale >= 1.0, "blind_sigma_scale", blind_sigma_scale);
  need(blind_drift_time_s > 0.0, "blind_drift_time_s", blind_drift_time_s);
  need(loop_sigma_p_m > 0.0 && loop_sigma_yaw_deg > 0.0, "loop_sigma_p_m", loop_sigma_p_m);
  need(loop_sigma_fit_scale > 0.0, "loop_sigma_fit_scale", loop_sigma_fit_scale);
  need(max_loop_residual_sigma > 0.0, "max_loop_residual_sigma", max_loop_residual_sigma);
  need(relocation_blend >= 0.0 && relocation_blend <= 1.0, "relocation_blend", relocation_blend);
  need(min_relocation_inliers >= 6, "min_relocation_inliers", min_relocation_inliers);
  need(relocation_max_change_m > 0.0, "relocation_max_change_m", relocation_max_change_m);
  need(relocation_max_change_deg > 0.0, "relocation_max_change_deg", relocation_max_change_deg);
  need(loop_sigma_min_p_m > 0.0 && loop_sigma_min_yaw_deg > 0.0, "loop_sigma_min_p_m", loop_sigma_min_p_m);
  need(verifier.min_matches >= 4, "verifier.min_matches", verifier.min_matches);
  need(verifier.max_hamming > 0 && verifier.max_hamming < 256, "verifier.max_hamming", verifier.max_hamming);
  need(verifier.ransac_iterations >= 1, "verifier.ransac_iterations", verifier.ransac_iterations);
  need(verifier.seed != 0, "verifier.seed", verifier.seed);  // xorshift stays at 0
  graph.validate();
  need(verifier.inlier_rad > 0.0, "verifier.inlier_rad", verifier.inlier_rad);
}

LoopCloser::LoopCloser(const LoopOptions& options, const RigCalibration& rig, const Vocabulary& vocabulary)
    : options_((options.validate(), options)),
      vocabulary_(vocabulary),
      // The keyframes' poses and points are the estimator's, whose body is the IMU.
      T_b_c0_(rig.imu.T_b_i.inverse() * rig.cam[0].T_b_c),
      describer_(capacity::kMaxImageWidth, capacity::kMaxImageHeight),
      verifier_(options.verifier, T_b_c0_),
      db_(new KeyframeDatabase(options.protected_recent)),
      index_(new InvertedIndex(vocabulary.nodes())),
      graph_(new PoseGraph4Dof()),
      pending_(new Pending[kPending]),
      prepared_(new LoopKeyframe()),
      scratch_(new Descriptor[capacity::kMaxLoopFeaturesPerKeyframe]),
      node_of_(new std::int32_t[capacity::kMaxKeyframes]),
      slot_of_(new std::uint32_t[capacity::kMaxKeyframes]),
      loops_(new LoopEdge[capacity::kMaxLoopEdges]),
      saved_(new SavedPose[capacity::kMaxKeyframes]),
      events_(new LoopEvent[capacity::kMaxLoopEvents]),
      request_(new RelocationRequest()),
      pair_q_(new std::uint16_t[capacity::kMaxLoopFeaturesPerKeyframe]),
      pair_c_(new std::uint16_t[capacity::kMaxLoopFeaturesPerKeyframe]),
      newest_landmarks_(new std::uint32_t[capacity::kMaxLoopFeaturesPerKeyframe]) {
  if (vocabulary.empty()) throw std::invalid_argument("loop closure: the vocabulary is empty");
  calibration_hash_ = hash_calibration(rig);
}

LoopCloser::~LoopCloser() = default;

void LoopCloser::on_keyframe_image(FrameId id, std::int64_t /*t_ns*/, const ImageView& left,
                                   const FrameFeatures& features) {
  const auto start = std::chrono::steady_clock::now();
  describe(id, left, features);
  const double ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
  ++stats_.described;
  stats_.describe_ms_sum += ms;
  stats_.max_describe_ms = std::max(stats_.max_describe_ms, ms);
}

void LoopCloser::describe(FrameId id, const ImageView& left, const FrameFeatures& features) {
  Pending& p = pending_[pending_next_];
  pending_next_ = (pending_next_ + 1) % kPending;
  p.id = kNoFrame;
  p.n = 0;
  if (!describer_.set_image(left)) return;  // the keyframe will count as without an image
  p.id = id;
  for (const FeatureObservation& f : features.features) {
    if (!f.has_left()) continue;
    if (!describer_.describe(f.uv_left_px.x(), f.uv_left_px.y(), &p.descriptor[p.n])) continue;
    p.feature_id[p.n++] = f.id;
  }
  // Ascending ids for the lookup when the keyframe leaves (insertion sort: about 200 entries).
  for (int i = 1; i < p.n; ++i) {
    const std::uint32_t id_i = p.feature_id[i];
    const Descriptor d_i = p.descriptor[i];
    int j = i - 1;
    for (; j >= 0 && p.feature_id[j] > id_i; --j) {
      p.feature_id[j + 1] = p.feature_id[j];
      p.descriptor[j + 1] = p.descriptor[j];
    }
    p.feature_id[j + 1] = id_i;
    p.descriptor[j + 1] = d_i;
  }
}

bool LoopCloser::map_from_odometry(std::uint32_t odometry_epoch, Eigen::Isometry3d* T_map_odom) const {
  return placement().map_from_odometry(odometry_epoch, T_map_odom);
}

void LoopCloser::begin_session(std::uint32_t epoch) {
  // The first levelled odometry frame defines the map; later ones wait for a verified loop.
  if (started_) ++session_;
  session_placed_ = !started_;
  started_ = true;
  epoch_ = epoch;
  ++stats_.sessions;
}

void LoopCloser::on_keyframe(const MarginalizedKeyframe& k) {
  prepare(k, prepared_.get());
  add_keyframe(*prepared_);
}

void LoopCloser::add_keyframe(const LoopKeyframe& k) {
  const auto start = std::chrono::steady_clock::now();
  keep(k);
  const double ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
  stats_.keyframe_ms_sum += ms;
  stats_.max_keyframe_ms = std::max(stats_.max_keyframe_ms, ms);
}

void LoopCloser::keep(const LoopKeyframe& k) {
  ++stats_.keyframes_in;
  if (!k.gravity_aligned) {
    ++stats_.keyframes_not_levelled;
    return;
  }
  if (!started_ || k.odometry_epoch != epoch_) begin_session(k.odometry_epoch);
  if (db_->full()) make_room();
  std::uint32_t slot = 0;
  if (db_->reserve(&slot) != Status::kOk) {
    ++stats_.keyframes_dropped;
    return;
  }
  build_record(k, slot);
  db_->commit(slot);
  if (!k.described) {
    ++stats_.keyframes_without_image;
    return;
  }
  KeyframeRecord& r = db_->at(slot);
  if (r.features.size() < static_cast<std::size_t>(options_.min_features)) {
    ++stats_.keyframes_not_indexed;
    return;
  }
  if (any_loop_ && r.t_ns - last_loop_t_ns_ < static_cast<std::int64_t>(options_.loop_interval_s * 1e9)) {
    ++stats_.queries_skipped;
  } else {
    query(slot);
  }
  if (index_->add(slot, r.bow) == Status::kOk) {
    r.indexed = true;
  } else {
    ++stats_.index_full;
  }
}

void LoopCloser::make_room() {
  const std::int32_t s = db_->pick_for_decimation();
  if (s < 0) return;
  KeyframeRecord& r = db_->at(static_cast<std::uint32_t>(s));
  if (r.indexed) index_->remove(static_cast<std::uint32_t>(s), r.bow);
  db_->remove(static_cast<std::uint32_t>(s));
  ++stats_.keyframes_decimated;
}

void LoopCloser::prepare(const MarginalizedKeyframe& k, LoopKeyframe* out) const {
  out->id = k.id;
  out->t_ns = k.t_ns;
  out->odometry_epoch = k.odometry_epoch;
  out->gravity_aligned = k.gravity_aligned;
  out->T_odom_b = k.T_odom_b;
  out->features.clear();
  const Pending* pend = nullptr;
  for (std::size_t i = 0; i < kPending; ++i) {
    if (pending_[i].id == k.id) pend = &pending_[i];
  }
  out->described = pend != nullptr;
  if (pend == nullptr || !k.gravity_aligned) return;
  const Eigen::Isometry3d T_b_odom = k.T_odom_b.inverse();
  for (const KeyframeObservation& o : k.observations) {
    if (!o.stereo || !o.has_point || !o.has_left || out->features.full()) continue;
    const std::uint32_t* end = pend->feature_id + pend->n;
    const std::uint32_t* it = std::lower_bound(pend->feature_id, end, o.landmark_id);
    if (it == end || *it != o.landmark_id) continue;
    LoopFeature f;
    f.descriptor = pend->descriptor[it - pend->feature_id];
    f.p_b = (T_b_odom * o.p_odom).cast<float>();
    f.bearing_c0 = o.bearing_left;
    out->landmark_id[out->features.size()] = o.landmark_id;
    out->features.push_back(f);
  }
}

void LoopCloser::build_record(const LoopKeyframe& k, std::uint32_t slot) {
  KeyframeRecord& r = db_->at(slot);
  r.id = k.id;
  r.t_ns = k.t_ns;
  r.session = session_;
  r.odometry_epoch = k.odometry_epoch;
  r.placed = session_placed_;
  r.T_odom_b = k.T_odom_b;
  r.T_map_b = T_map_odom_ * k.T_odom_b;
  const std::int32_t prev = db_->newest();
  r.path_m = 0.0;
  if (prev >= 0 && db_->at(prev).session == session_) {
    const KeyframeRecord& p = db_->at(prev);
    r.path_m = p.path_m + (k.T_odom_b.translation() - p.T_odom_b.translation()).norm();
  }
  r.features.clear();
  for (const LoopFeature& f : k.features) r.features.push_back(f);
  std::copy(k.landmark_id, k.landmark_id + k.features.size(), newest_landmarks_.get());
  newest_slot_ = slot;
  for (std::size_t i = 0; i < r.features.size(); ++i) scratch_[i] = r.features[i].descriptor;
  vocabulary_.transform(scratch_.get(), r.features.size(), &r.bow);
}

}  // namespace ums::loop

namespace ums::loop {

void LoopCloser::query(std::uint32_t slot) {
  ++stats_.queries;
  const KeyframeRecord& q = db_->at(slot);
  // DBoW2's normalisation: a candidate must look at least this much like the query as the
  // query's own predecessor does (a textureless view scores low against everything).
  float prev_score = 1.0f;
  for (std::int32_t s = q.prev; s >= 0 && db_->at(s).session == q.session; s = db_->at(s).prev) {
    if (db_->at(s).indexed) {
      prev_score = bow_score(q.bow, db_->at(s).bow);
      break;
    }
  }
  const std::int64_t cutoff_ns = q.t_ns - static_cast<std::int64_t>(options_.recent_s * 1e9);
  auto allowed = [&](std::uint32_t s) {
    const KeyframeRecord& c = db_->at(s);
    if (!c.placed) return false;
    return c.session != q.session || c.t_ns < cutoff_ns;
  };
  IndexHit hits[16];
  const int n = index_->query(q.bow, allowed, hits, options_.candidates);
  for (int h = 0; h < n; ++h) {
    ++stats_.candidates;
    if (hits[h].score < options_.min_score || hits[h].score < options_.min_normalized_score * prev_score) {
      reject(LoopGate::kScore);
      continue;
    }
    LoopGeometry g;
    const bool ok = verifier_.verify(q, db_->at(hits[h].keyframe), &g);
    if (!ok && g.matches < options_.verifier.min_matches) {
      reject(LoopGate::kMatches);
      continue;
    }
    if (!ok || g.inliers < options_.min_inliers) {
      reject(LoopGate::kInliers);
      continue;
    }
    if (passes_gates(slot, hits[h].keyframe, g) && close_loop(slot, hits[h].keyframe, g)) return;
  }
}

bool LoopCloser::passes_gates(std::uint32_t q_slot, std::uint32_t c_slot, const LoopGeometry& g) {
  const KeyframeRecord& q = db_->at(q_slot);
  const KeyframeRecord& c = db_->at(c_slot);
  if (static_cast<double>(g.inliers) < options_.min_inlier_ratio * g.matches) {
    reject(LoopGate::kInlierRatio);
    return false;
  }
  // Both frames are levelled to gravity: the loop must agree on the query's roll and pitch.
  const bool q_placed = q.placed;
  const Eigen::Matrix3d R_q = (q_placed ? q.T_map_b : q.T_odom_b).linear();
  const Eigen::Matrix3d R_q_loop = c.T_map_b.linear() * g.T_c_q.linear();
  const Eigen::Vector3d up_q = R_q.transpose() * Eigen::Vector3d::UnitZ();
  const Eigen::Vector3d up_loop = R_q_loop.transpose() * Eigen::Vector3d::UnitZ();
  if (std::acos(std::min(1.0, up_q.dot(up_loop))) * kDegPerRad > options_.max_gravity_deg) {
    reject(LoopGate::kGravity);
    return false;
  }
  if (!q_placed || q.session != c.session) return true;  // no drift budget across sessions
  // Drift budget (OKVIS2): the loop may move the query no more than odometry can have drifted.
  const Eigen::Isometry3d E = (c.T_map_b * g.T_c_q).inverse() * q.T_map_b;
  const double flown_m = std::abs(q.path_m - c.path_m);
  const double dyaw_deg = std::abs(quat::wrap_angle_rad(quat::yaw(E.linear()))) * kDegPerRad;
  if (E.translation().norm() > options_.drift_base_m + options_.drift_per_m * flown_m ||
      dyaw_deg > options_.drift_base_deg + options_.drift_per_m_deg * flown_m) {
    reject(LoopGate::kDriftBudget);
    return false;
  }
  return true;
}

bool LoopCloser::close_loop(std::uint32_t q_slot, std::uint32_t c_slot, const LoopGeometry& g) {
  // A full set of loop edges makes room with its oldest, put back if the new loop is refused.
  const bool retired = n_loops_ == capacity::kMaxLoopEdges;
  const LoopEdge oldest = retired ? retire_oldest_loop() : LoopEdge{};
  KeyframeRecord& q = db_->at(q_slot);
  KeyframeRecord& c = db_->at(c_slot);
  const bool relocalization = !q.placed;
  save_map_state();
  if (relocalization) place_session(q, c.T_map_b * g.T_c_q, true);
  const Eigen::Isometry3d T_map_q_before = q.T_map_b;
  const LoopEdge edge{c_slot, q_slot, g.T_c_q,
                      std::max(options_.loop_sigma_min_p_m, options_.loop_sigma_fit_scale * g.sigma_p_m),
                      std::max(options_.loop_sigma_min_yaw_deg / kDegPerRad, options_.loop_sigma_fit_scale * g.sigma_rot_rad)};
  loops_[n_loops_++] = edge;
  // The solved graph must agree with the loop: one it can only hold off under the robust loss
  // (a place that looks like another, within the drift budget of a long path) is refused.
  if (!solve_graph() || loop_residual_sigma(edge) > options_.max_loop_residual_sigma) {
    --n_loops_;
    restore_map_state();
    if (retired) unretire(oldest);
    reject(LoopGate::kPoseGraph);
    return false;
  }
  if (retired) ++stats_.loop_edges_retired;
  ++q.loops;
  ++c.loops;
  ++stats_.accepted;
  any_loop_ = true;
  last_loop_t_ns_ = q.t_ns;
  if (relocalization) ++stats_.relocalizations;
  if (n_events_ >= capacity::kMaxLoopEvents) ++stats_.events_overwritten;
  LoopEvent& e = events_[n_events_++ % capacity::kMaxLoopEvents];
  e = LoopEvent{q.t_ns, c.t_ns, q.id, c.id, g.inliers,
                (q.T_map_b.translation() - T_map_q_before.translation()).norm(),
                angle_deg(T_map_q_before.linear().transpose() * q.T_map_b.linear()), relocalization,
                g.T_c_q, q.T_map_b.translation(), c.T_map_b.translation(), g.sigma_p_m,
                g.sigma_rot_rad * kDegPerRad};
  stats_.max_correction_m = std::max(stats_.max_correction_m, e.correction_m);
  if (options_.tight_relocation) request_relocation(q, c, g);
  return true;
}

double LoopCloser::loop_residual_sigma(const LoopEdge& l) const {
  const Eigen::Isometry3d E = (db_->at(l.c_slot).T_map_b * l.T_c_q).inverse() * db_->at(l.q_slot).T_map_b;
  return std::max(E.translation().norm() / l.sigma_p_m, std::abs(quat::wrap_angle_rad(quat::yaw(E.linear()))) / l.sigma_yaw_rad);
}

void LoopCloser::save_map_state() {
  for (std::int32_t s = db_->oldest(); s >= 0; s = db_->at(s).next) {
    saved_[s] = SavedPose{db_->at(s).T_map_b, db_->at(s).placed};
  }
  saved_T_map_odom_ = T_map_odom_;
  saved_session_placed_ = session_placed_;
  saved_corrections_ = corrections_;
}

void LoopCloser::restore_map_state() {
  for (std::int32_t s = db_->oldest(); s >= 0; s = db_->at(s).next) {
    db_->at(s).T_map_b = saved_[s].T_map_b;
    db_->at(s).placed = saved_[s].placed;
  }
  T_map_odom_ = saved_T_map_odom_;
  session_placed_ = saved_session_placed_;
  corrections_ = saved_corrections_;
}

LoopCloser::LoopEdge LoopCloser::retire_oldest_loop() {
  // The newer loops cover the places flown again; the oldest edge's ends may be decimated again.
  const LoopEdge old = loops_[0];
  for (std::uint32_t s : {old.c_slot, old.q_slot}) {
    if (db_->at(s).loops > 0) --db_->at(s).loops;
  }
  for (std::size_t l = 1; l < n_loops_; ++l) loops_[l - 1] = loops_[l];
  --n_loops_;
  return old;
}

void LoopCloser::unretire(const LoopEdge& edge) {
  for (std::size_t l = n_loops_; l > 0; --l) loops_[l] = loops_[l - 1];
  loops_[0] = edge;
  ++n_loops_;
  for (std::uint32_t s : {edge.c_slot, edge.q_slot}) ++db_->at(s).loops;
}

void LoopCloser::place_session(const KeyframeRecord& q, const Eigen::Isometry3d& T_map_q, bool placed) {
  // Both odometry frames are levelled to gravity: the placement is a yaw and a translation (the
  // loop's own roll/pitch error, up to the gravity gate, must not tilt the session).
  const Eigen::Matrix3d R = T_map_q.linear() * q.T_odom_b.linear().transpose();
  T_map_odom_.setIdentity();
  T_map_odom_.linear() = Eigen::AngleAxisd(quat::yaw(R), Eigen::Vector3d::UnitZ()).toRotationMatrix();
  T_map_odom_.translation() = T_map_q.translation() - T_map_odom_.linear() * q.T_odom_b.translation();
  if (q.session == session_) session_placed_ = placed;
  for (std::int32_t s = db_->oldest(); s >= 0; s = db_->at(s).next) {
    KeyframeRecord& r = db_->at(s);
    if (r.session != q.session) continue;
    r.placed = placed;
    r.T_map_b = T_map_odom_ * r.T_odom_b;
  }
}

LoopCloser::OdometrySigmas LoopCloser::odometry_sigmas(const KeyframeRecord& a, const KeyframeRecord& b, double d_m,
                                                       std::int64_t* blind_since_ns) const {
  double p_scale = 1.0, yaw_scale = 1.0;
  if (std::min(a.features.size(), b.features.size()) < static_cast<std::size_t>(options_.min_features)) {
    if (*blind_since_ns < 0) *blind_since_ns = a.t_ns;
    // Dead reckoning's position error grows by its velocity error, which grows with the time since
    // the images went (accelerometer bias, tilt): the later in the stretch, the more of the loop's
    // correction an edge takes (variance in proportion to the edge's expected drift). The yaw
    // drifts at the gyro bias's constant rate.
    const double since_s = 1e-9 * static_cast<double>((a.t_ns - *blind_since_ns) + (b.t_ns - a.t_ns) / 2);
    yaw_scale = options_.blind_sigma_scale;
    p_scale = yaw_scale * std::sqrt(1.0 + std::max(0.0, since_s) / options_.blind_drift_time_s);
  } else {
    *blind_since_ns = -1;
  }
  return {p_scale * (options_.odom_sigma_p_m + options_.odom_sigma_p_per_m * d_m),
          yaw_scale * (options_.odom_sigma_yaw_deg + options_.odom_sigma_yaw_deg_per_m * d_m) / kDegPerRad};
}

bool LoopCloser::solve_graph() {
  const auto start = std::chrono::steady_clock::now();
  graph_->clear();
  std::int32_t prev_node = -1;
  std::uint32_t prev_slot = 0;
  std::int64_t blind_since_ns = -1;  // start of the blind stretch the chain is in, or -1
  for (std::int32_t s = db_->oldest(); s >= 0; s = db_->at(s).next) {
    const KeyframeRecord& r = db_->at(s);
    node_of_[s] = -1;
    if (!r.placed) continue;
    int node = -1;
    if (graph_->add_node(r.T_map_b, &node) != Status::kOk) return false;
    node_of_[s] = node;
    slot_of_[node] = static_cast<std::uint32_t>(s);
    if (prev_node >= 0 && db_->at(prev_slot).session == r.session) {
      const Eigen::Isometry3d T_i_j = db_->at(prev_slot).T_odom_b.inverse() * r.T_odom_b;
      const OdometrySigmas sig = odometry_sigmas(db_->at(prev_slot), r, T_i_j.translation().norm(), &blind_since_ns);
      graph_->add_edge(prev_node, node, T_i_j, sig.p_m, sig.yaw_rad, EdgeKind::kOdometry);
    } else {
      blind_since_ns = -1;
    }
    prev_node = node;
    prev_slot = static_cast<std::uint32_t>(s);
  }
  if (graph_->num_nodes() < 2) return false;
  graph_->set_fixed(0, true);
  for (std::size_t l = 0; l < n_loops_; ++l) {
    const std::int32_t a = node_of_[loops_[l].c_slot], b = node_of_[loops_[l].q_slot];
    if (a < 0 || b < 0) continue;
    graph_->add_edge(a, b, loops_[l].T_c_q, loops_[l].sigma_p_m, loops_[l].sigma_yaw_rad, EdgeKind::kLoop);
  }
  graph_->optimize(options_.graph);
  for (int i = 0; i < graph_->num_nodes(); ++i) db_->at(slot_of_[i]).T_map_b = graph_->pose(i);
  const KeyframeRecord& newest = db_->at(db_->newest());
  if (newest.session == session_) T_map_odom_ = newest.T_map_b * newest.T_odom_b.inverse();
  ++corrections_;
  stats_.max_pose_graph_ms = std::max(stats_.max_pose_graph_ms,
      std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count());
  return true;
}

std::size_t LoopCloser::footprint_bytes() const {
  return db_->footprint_bytes() + index_->footprint_bytes() + graph_->footprint_bytes() +
         kPending * sizeof(Pending) + sizeof(LoopKeyframe) + capacity::kMaxLoopFeaturesPerKeyframe * sizeof(Descriptor) +
         capacity::kMaxKeyframes * (sizeof(std::int32_t) + sizeof(std::uint32_t)) +
         capacity::kMaxLoopEdges * sizeof(LoopEdge) + capacity::kMaxLoopEvents * sizeof(LoopEvent) +
         capacity::kMaxKeyframes * sizeof(SavedPose) + sizeof(RelocationRequest) +
         capacity::kMaxLoopFeaturesPerKeyframe * (2 * sizeof(std::uint16_t) + sizeof(std::uint32_t)) + sizeof(*this);
}

}  // namespace ums::loop
