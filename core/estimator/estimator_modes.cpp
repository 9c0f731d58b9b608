// The per-mode work of one frame (paper Sec. III-B, III-C) and the window's upkeep.
#include <algorithm>
#include <chrono>
#include <cmath>

#include <Eigen/Eigenvalues>

#include "core/estimator/estimator.hpp"
#include "core/estimator/imu_buffer.hpp"
#include "core/estimator/initializer.hpp"
#include "core/estimator/landmark_map.hpp"
#include "core/estimator/marginalizer.hpp"
#include "solver/problem.hpp"
#include "core/estimator/pnp_locator.hpp"
#include "core/estimator/problem_builder.hpp"
#include "core/estimator/state_blocks.hpp"
#include "core/estimator/window.hpp"
#include "core/estimator/window_backup.hpp"
#include "core/math/so3.hpp"

namespace ums {
ModeEvent Estimator::frame_imu_only(WindowFrame& f) {
  // Case 1: the pose is the IMU's; keep trying the stereo visual initialization.
  if (window_->size() < 2) {
    landmarks_->triangulate_all(*window_, -1);
    return ModeEvent::kNone;
  }
  if (!initializer_->visual_step(pnp_.get())) {
    ++stats_.visual_init_failures;
    reset_window(true);
    landmarks_->triangulate_all(*window_, -1);
    return ModeEvent::kNone;
  }
  set_nav_from(f);
  if (f.still && last_still_valid_) return initializer_->standstill(last_still_);
  frames_since_align_ = options_.align_retry_frames;  // try at once when the window allows
  return ModeEvent::kVisualInit;
}

ModeEvent Estimator::frame_vo(WindowFrame& f) {
  const int n = window_->size();
  const WindowFrame& prev = window_->at(n - 2);
  const double dt = static_cast<double>(f.t_ns - prev.t_ns) * 1e-9;
  Eigen::Isometry3d prior = iso_from_pose(prev.pose);
  prior.translation() += vo_velocity_ * dt;
  if (f.imu_ok) {
    Eigen::Vector3d alpha, beta;
    Eigen::Quaterniond gamma;
    f.pre.corrected(state::ba(prev.sb), state::bg(prev.sb), &alpha, &beta, &gamma);
    prior.linear() = prior.linear() * gamma.toRotationMatrix();
  }
  pose_from_iso(prior, f.pose);
  if (!pnp_->locate(*window_, *landmarks_, window_->slot_of(f), prior)) {
    ++stats_.resets;
    set_nav_from(f);
    reset_window(true);
    landmarks_->triangulate_all(*window_, -1);
    return ModeEvent::kVisionLost;
  }
  landmarks_->triangulate_all(*window_, -1);
  SolveSpec spec;
  spec.groups = kAllGroups;
  spec.imu = false;
  spec.prior = false;
  spec.fix_first_pose = true;
  bool converged = false;
  builder_->solve(spec, round1_budget(f), &converged);
  second_round(spec, converged);
  if (dt > 0.0) vo_velocity_ = (state::p(f.pose) - state::p(prev.pose)) / dt;
  state::v(f.sb) = vo_velocity_;
  ++frames_since_align_;
  if (f.still && prev.still && last_still_valid_) return initializer_->standstill(last_still_);
  const double span_s = static_cast<double>(f.t_ns - window_->at(0).t_ns) * 1e-9;
  if (n >= options_.min_align_frames && span_s >= options_.min_align_span_s &&
      frames_since_align_ >= options_.align_retry_frames) {
    frames_since_align_ = 0;
    return initializer_->align();
  }
  return ModeEvent::kNone;
}

void Estimator::second_round(const SolveSpec& spec, bool converged) {
  // Round 2 (paper Sec. III-C) on the cleaned set when round 1 was cut short or removed enough
  // (round2_min_outlier_share), bounded by time; nothing to refine when round 1 converged without
  // outliers. Cut short with nothing removed, it continues on round 1's problem as built
  // (solve_again).
  const int in_solve = builder_->num_selected();
  const int outliers = builder_->mark_outliers();
  const bool enough = outliers > 0 && outliers >= options_.round2_min_outlier_share * in_solve;
  // A relocation's counts (ProblemBuilder::relocation_inliers) read the problem: no outlier kept.
  if (enough || !converged || (outliers > 0 && builder_->relocating())) {
    if (outliers > 0) landmarks_->compact();
    builder_->solve_again(spec, {std::max(1, options_.max_iterations_round2), 0, options_.round2_time_s});
    ++stats_.second_rounds;
    return;
  }
  if (outliers == 0) return;
  // The outliers stay in the map, marked, until the end of the frame: the marginalization reads
  // round 1's problem (slide_window).
  ++stats_.second_rounds_skipped;
  builder_->keep_outliers();
}

// VIO cannot see a rotation about gravity or a translation of the whole window: only the prior's
// linearization holds them, weakly. After the solves the window is moved back so that its oldest
// frame keeps the position and the heading it had (VINS-Mono does the same), which costs vision
// and the IMU nothing. The yaw is taken from the small rotation between the oldest frame's
// attitudes without atan2 (the host and aarch64 builds must agree bit for bit).
void Estimator::hold_gauge(const Eigen::Isometry3d& T_w_b0_before) {
  const Eigen::Isometry3d T_w_b0 = window_->T_w_b(window_->slot_at(0));
  const Eigen::Matrix3d R_d = T_w_b0_before.linear() * T_w_b0.linear().transpose();
  const Eigen::Vector2d cs(R_d(0, 0), R_d(1, 0));
  const double n = cs.norm();
  if (!(n > 1e-6)) return;  // the oldest frame turned about a horizontal axis by 90 deg: no yaw
  Eigen::Matrix3d R_z = Eigen::Matrix3d::Identity();
  R_z(0, 0) = R_z(1, 1) = cs.x() / n;
  R_z(1, 0) = cs.y() / n;
  R_z(0, 1) = -cs.y() / n;
  window_->move(R_z, T_w_b0.translation(), T_w_b0_before.translation());
  builder_->note_window_moved(R_z);
}

void Estimator::frame_vio(WindowFrame& f, EstimatorTiming* timing) {
  const Eigen::Isometry3d T_w_b0_before = window_->T_w_b(window_->slot_at(0));
  landmarks_->triangulate_all(*window_, window_->slot_of(f));
  window_->update_imu_factors(g_w_);
  const auto t1 = std::chrono::steady_clock::now();
  SolveSpec spec;
  spec.imu = true;
  spec.prior = true;
  const bool relocating = begin_relocation();
  release_extrinsics_when_excited(f.t_ns);
  const bool converged = solve_stages(f, &spec);
  timing->solve_round1_ms = static_cast<float>(ms_since(t1));
  const auto t2 = std::chrono::steady_clock::now();
  second_round(spec, converged);
  timing->solve_round2_ms = static_cast<float>(ms_since(t2));
  // The loop keyframe's pose relative to the oldest frame, which hold_gauge() keeps in place.
  const Eigen::Isometry3d T_b0_loop = relocating ? window_->T_w_b(window_->slot_at(0)).inverse() * builder_->relocation_pose()
                                                 : Eigen::Isometry3d::Identity();
  hold_gauge(T_w_b0_before);
  if (options_.estimate_td && window_->time_offset().clamp(options_.td_max_change_ms * 1e-3)) ++stats_.td_clamped;
  if (options_.estimate_gyro_scale && window_->gyro_scale().clamp(options_.gyro_scale_max_pct * 1e-2))
    ++stats_.gyro_scale_clamped;
  if (relocating) end_relocation(T_b0_loop, spec);
}

void Estimator::release_extrinsics_when_excited(std::int64_t t_ns) {
  if (!options_.estimate_extrinsic || builder_->extrinsics_released()) return;
  const double excitation_deg = rotation_excitation_deg();
  stats_.max_rotation_excitation_deg = std::max(stats_.max_rotation_excitation_deg, excitation_deg);
  if (excitation_deg < options_.extrinsic_release_deg) return;
  builder_->release_extrinsics();
  stats_.extrinsic_released_t_ns = t_ns;
}

double Estimator::rotation_excitation_deg() const {
  Eigen::Matrix3d M = Eigen::Matrix3d::Zero();
  for (int k = 1; k < window_->size(); ++k) {
    const Eigen::Matrix3d R_a = window_->T_w_b(window_->slot_at(k - 1)).linear();
    const Eigen::Matrix3d R_b = window_->T_w_b(window_->slot_at(k)).linear();
    const Eigen::Vector3d phi = so3::log(Eigen::Matrix3d(R_a.transpose() * R_b));
    M += phi * phi.transpose();
  }
  const double least = Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d>(M, Eigen::EigenvaluesOnly).eigenvalues()(0);
  return std::sqrt(std::max(least, 0.0)) * 180.0 / M_PI;
}

bool Estimator::begin_relocation() {
  if (relocation_link_ == nullptr || !relocation_link_->take_relocation(relocation_.get())) return false;
  ++stats_.relocation_requests;
  const RelocationRequest& r = *relocation_;
  if (r.odometry_epoch != static_cast<std::uint32_t>(stats_.resets + stats_.relevels)) {
    // q's odometry frame is gone (a reset since): nothing in the window shares its landmarks.
    RelocationResult none;
    none.query = r.query;
    none.loop = r.loop;
    relocation_link_->on_relocated(none);
    return false;
  }
  builder_->set_relocation(&r, r.T_odom_q * r.T_q_loop);
  return true;
}

void Estimator::end_relocation(const Eigen::Isometry3d& T_b0_loop, const SolveSpec& spec) {
  RelocationResult res;
  res.query = relocation_->query;
  res.loop = relocation_->loop;
  res.residuals = builder_->relocation_residuals();
  if (res.residuals > 0) {
    res.inliers = builder_->relocation_inliers();
    const Eigen::Isometry3d T_odom_loop = window_->T_w_b(window_->slot_at(0)) * T_b0_loop;
    res.T_loop_query = T_odom_loop.inverse() * relocation_->T_odom_q;
    ++stats_.relocations_solved;
    stats_.relocation_residuals += static_cast<std::uint64_t>(res.residuals);
  }
  builder_->clear_relocation(spec);
  relocation_link_->on_relocated(res);
}

// A keyframe's solve ends in the linearization its marginalization reuses (slide_window): cut
// short, the marginalization would linearize its landmarks again, and the prior would hold
// states one step from their optimum.
SolveBudget Estimator::round1_budget(const WindowFrame& f) const {
  const bool exempt = f.keyframe && !options_.max_steps_at_keyframes;
  return {options_.max_iterations_stage, exempt ? 0 : options_.max_steps_stage};
}

bool Estimator::solve_stages(WindowFrame& f, SolveSpec* spec) {
  const SolveBudget budget = round1_budget(f);
  bool converged = false;
  if (!options_.two_stage) {
    spec->groups = kAllGroups;
    builder_->solve(*spec, budget, &converged);
  } else if (count_candidates(*landmarks_, k3DGroup) < options_.min_3d_landmarks) {
    spec->groups = kAllGroups;
    builder_->solve(*spec, budget, &converged);
    ++stats_.stage_added_2d_right;
  } else if (const int n_2d_left = count_candidates(*landmarks_, k2DLeftGroup); n_2d_left == 0) {
    // No 2D-left landmark to add: the second stage would be the first again.
    spec->groups = k3DGroup;
    builder_->solve(*spec, budget, &converged);
    ++stats_.stage_3d_sufficient;
  } else if (n_2d_left < options_.stage_min_2d_left) {
    // A handful of 2D-left landmarks beside the stereo ones cannot move the pose away from the
    // stereo-only solution: the comparison would cost a solve and always agree.
    spec->groups = k3DGroup | k2DLeftGroup;
    builder_->solve(*spec, budget, &converged);
    ++stats_.stage_few_2d_left;
  } else {
    // The paper's two stages: stereo alone and stereo + 2D-left from the same start; agreement
    // keeps the latter, disagreement brings in the 2D-right features as well.
    save_window(*window_, *landmarks_, stage_backup_.get());
    spec->groups = k3DGroup;
    builder_->solve(*spec, {options_.max_iterations_stage_a});
    const Eigen::Vector3d p_a = state::p(f.pose);
    const Eigen::Quaterniond q_a = quat_of(f.pose).normalized();
    restore_window(*stage_backup_, window_.get(), landmarks_.get());
    spec->groups = k3DGroup | k2DLeftGroup;
    builder_->solve(*spec, budget, &converged);
    const double dp = (state::p(f.pose) - p_a).norm();
    const double dq_deg = q_a.angularDistance(quat_of(f.pose).normalized()) * 180.0 / M_PI;
    if (dp <= options_.stage_agree_m && dq_deg <= options_.stage_agree_deg) {
      ++stats_.stage_kept_2d_left;
    } else {
      restore_window(*stage_backup_, window_.get(), landmarks_.get());
      spec->groups = kAllGroups;
      builder_->solve(*spec, budget, &converged);
      ++stats_.stage_added_2d_right;
    }
  }
  return converged;
}

// ---------------------------------------------------------------------------------------------
// Window upkeep

void Estimator::remove_frame(int pos) {
  // Without the IMU nothing but vision holds the window: keep the points (landmark_map.hpp).
  const Rehost how = inertial_window() ? Rehost::kMeasuredRay : Rehost::kKeepPoint;
  landmarks_->remove_frame(window_->slot_at(pos), *window_, how);
  window_->erase(pos);
}

void Estimator::reset_window(bool keep_newest) {
  const bool keep = keep_newest && !window_->empty();
  while (window_->size() > (keep ? 1 : 0)) remove_frame(0);
  if (!keep) landmarks_->clear_observations();
  marginalizer_->clear();
  builder_->clear_init_prior();
  keyframes_.reset();
}

// Marginalization (paper Sec. III-C): the oldest frame and the landmarks it hosts go into the
// prior when the newest frame is a keyframe (and the oldest leaves through the keyframe outlet);
// otherwise the second newest frame is dropped, its IMU interval merged into the newest one's,
// and only removed from the prior if the prior holds it.
void Estimator::slide_window(EstimatorTiming* timing) {
  const int frames = window_->size();
  if (frames >= 2 && (frames < options_.window_size || window_->newest().keyframe)) {
    settled_ = window_->at(frames - 2).id;
  }
  if (frames < options_.window_size) return;
  const auto t0 = std::chrono::steady_clock::now();
  WindowFrame& newest = window_->newest();
  const bool vio = inertial_window();
  if (newest.keyframe) {
    int ids[2 + capacity::kMaxLandmarks];
    int outliers = 0;
    int n = vio ? builder_->oldest_frame_blocks(ids, &outliers) : 0;
    // An outlier kept in round 1's problem (second_round) and seen from the oldest frame would
    // enter the prior: the problem is built again without the outliers.
    if (outliers > 0 && builder_->rebuild_without_kept_outliers()) {
      ++stats_.second_round_rebuilds;
      n = builder_->oldest_frame_blocks(ids, &outliers);
    }
    stats_.outliers_into_prior += static_cast<std::uint64_t>(outliers);
    if (vio && !marginalizer_->adopt(builder_->problem(), builder_->blocks(), ids, n))
      ++stats_.marginalization_failures;
    else if (vio && builder_->problem().marginalization_reused())
      ++stats_.marginalizations_reused;
    if (mode_ != EstimatorMode::kImuOnly) {
      marginalizer_->emit_keyframe(*window_, 0, *landmarks_,
                                   static_cast<std::uint32_t>(stats_.resets + stats_.relevels), vio);
    }
    remove_frame(0);
    ++stats_.marginalized_old;
  } else {
    const int pos = window_->size() - 2;
    WindowFrame& second = window_->at(pos);
    if (vio && !marginalizer_->marginalize_frame(second.id, *window_, builder_->problem(), &builder_->blocks()))
      ++stats_.marginalization_failures;
    merge_into_newest(second, newest);
    remove_frame(pos);
    ++stats_.marginalized_second_new;
  }
  timing->marginalize_ms += static_cast<float>(ms_since(t0));
}

void Estimator::merge_into_newest(WindowFrame& second, WindowFrame& newest) {
  // newest.pre = pre(second) followed by pre(newest), re-integrated from the stored samples.
  ImuSample* scratch = imu_->scratch();
  const std::size_t m = newest.pre.num_samples();
  for (std::size_t k = 0; k < m; ++k) scratch[k] = newest.pre.sample(k);
  // Unmeasured motion of either part stays unmeasured; the first part's velocity error also
  // moves the position over the second part.
  Preintegration::UnmodelledMotion unmodelled = second.pre.unmodelled_motion();
  unmodelled.lever_s += newest.pre.dt_s();
  const Preintegration::UnmodelledMotion unmodelled_newest = newest.pre.unmodelled_motion();
  if (second.pre.num_samples() >= 1 && m >= 1) {
    const Eigen::Vector3d ba = second.pre.linearization_ba(), bg = second.pre.linearization_bg();
    newest.pre.reset(second.pre.sample(0), ba, bg);
    for (std::size_t k = 1; k < second.pre.num_samples(); ++k)
      if (newest.pre.add(second.pre.sample(k)) == Status::kFull) ++stats_.drops_imu;
    for (std::size_t k = 1; k < m; ++k)
      if (newest.pre.add(scratch[k]) == Status::kFull) ++stats_.drops_imu;
    if (second.pre.has_unmodelled_motion()) newest.pre.add_unmodelled_motion(unmodelled);
    newest.pre.add_unmodelled_motion(unmodelled_newest);
    newest.imu_ok = second.imu_ok && newest.imu_ok && newest.imu.residual().init(&newest.pre, g_w_) == Status::kOk;
  } else {
    newest.imu_ok = false;
  }
  newest.still = newest.still && second.still;
}

}  // namespace ums
