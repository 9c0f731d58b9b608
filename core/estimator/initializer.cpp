#include "core/estimator/initializer.hpp"

#include <algorithm>
#include <cmath>

#include "core/estimator/estimator_stats.hpp"
#include "core/estimator/imu_alignment.hpp"
#include "core/estimator/imu_buffer.hpp"
#include "core/estimator/landmark_map.hpp"
#include "core/estimator/marginalizer.hpp"
#include "core/estimator/pnp_locator.hpp"
#include "core/estimator/problem_builder.hpp"
#include "core/estimator/state_blocks.hpp"
#include "core/estimator/window.hpp"
#include "core/estimator/window_backup.hpp"

namespace ums {
namespace {


using Vector9 = SpeedBiasPrior::Vector9;

}  // namespace

Initializer::Initializer(const EstimatorOptions& options, const RigCalibration& rig, Window* window,
                         LandmarkMap* landmarks, ProblemBuilder* builder, Marginalizer* marginalizer,
                         EstimatorStats* stats)
    : options_(options),
      noise_(ImuNoise::from_calibration(rig.imu)),
      g_w_(0.0, 0.0, -options.gravity_m_s2),
      window_(window),
      landmarks_(landmarks),
      builder_(builder),
      marginalizer_(marginalizer),
      stats_(stats),
      vo_state_(std::make_unique<WindowBackup>()) {}

Initializer::~Initializer() = default;

bool Initializer::imu_at_rest(std::int64_t t_ns, ImuBuffer* imu, StandstillResult* result) const {
  const std::int64_t window_ns = static_cast<std::int64_t>(options_.standstill_window_s * 1e9);
  const int n = imu->copy_recent(t_ns - window_ns, t_ns);
  const ImuSample* s = imu->scratch();
  const Status st = detect_standstill(s, static_cast<std::size_t>(n), noise_, options_.standstill, result);
  // A window shorter than asked (start of the data) is not trusted.
  if (st != Status::kOk) return false;
  if (n > 1 && (s[n - 1].t_ns - s[0].t_ns) < window_ns * 9 / 10) return false;
  return result->at_rest;
}

float Initializer::visual_flow_px(int prev_slot, int slot, const Eigen::Vector3d& bg) const {
  // Rotation between the frames from the gyro (bias bg) taken out: translation only.
  const WindowFrame& f = window_->slot(slot);
  Eigen::Matrix3d R_prev_cur = Eigen::Matrix3d::Identity();
  if (f.pre.num_samples() >= 2) {
    const Eigen::Matrix3d R_b_c = window_->extrinsics().T_b_c(0).linear();
    Eigen::Vector3d alpha, beta;
    Eigen::Quaterniond gamma;
    f.pre.corrected(f.pre.linearization_ba(), bg, &alpha, &beta, &gamma);
    R_prev_cur = R_b_c.transpose() * gamma.toRotationMatrix() * R_b_c;
  }
  double sum = 0.0;
  int n = 0;
  for (int k = 0; k < landmarks_->size(); ++k) {
    const Landmark& l = (*landmarks_)[k];
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

bool Initializer::vision_only_ba(int iterations) {
  SolveSpec spec;
  spec.groups = kAllGroups;
  spec.imu = false;
  spec.prior = false;
  spec.fix_first_pose = true;
  const bool ok = builder_->solve(spec, {iterations});
  if (builder_->mark_outliers() > 0) landmarks_->compact();
  return ok;
}

bool Initializer::visual_step(PnpLocator* pnp) {
  const int slot = window_->slot_at(window_->size() - 1);
  const Eigen::Isometry3d prior = iso_from_pose(window_->slot(slot).pose);
  if (!pnp->locate(*window_, *landmarks_, slot, prior)) return false;
  landmarks_->triangulate_all(*window_, -1);
  vision_only_ba(6);
  return true;
}

ModeEvent Initializer::standstill(const StandstillResult& rest) {
  WindowFrame& newest = window_->newest();
  const Eigen::Vector3d up_w = quat_of(newest.pose).normalized() * rest.mean_accel_m_s2;
  window_->rotate(rotation_between(up_w, Eigen::Vector3d::UnitZ()), state::p(newest.pose));
  const Eigen::Vector3d bg = rest.mean_gyro_rad_s;
  for (int k = 0; k < window_->size(); ++k) {
    WindowFrame& f = window_->at(k);
    Eigen::Map<Vector9> sb(f.sb);
    sb.setZero();
    state::bg(f.sb) = bg;
    if (k > 0 && f.pre.num_samples() >= 2) f.pre.repropagate(Eigen::Vector3d::Zero(), bg);
  }
  window_->update_imu_factors(g_w_);
  Vector9 target = Vector9::Zero();
  target.segment<3>(state::kSbBg) = bg;
  Vector9 sigma = Vector9::Zero();
  sigma.segment<3>(state::kSbBa).setConstant(options_.init_bias_sigma_ba);
  sigma.segment<3>(state::kSbBg).setConstant(options_.init_bias_sigma_bg);
  builder_->set_init_prior(target, sigma, window_->at(0).id);
  marginalizer_->clear();
  return ModeEvent::kStandstill;
}

ModeEvent Initializer::fail(bool unobservable) {
  restore_window(*vo_state_, window_, landmarks_);
  builder_->clear_init_prior();
  marginalizer_->clear();
  ++stats_->align_failures;
  if (unobservable) ++stats_->align_unobservable;
  return ModeEvent::kNone;
}

ModeEvent Initializer::align() {
  ++stats_->align_attempts;
  save_window(*window_, *landmarks_, vo_state_.get());  // the VO state, restored on failure
  Eigen::Vector3d bg = Eigen::Vector3d::Zero();
  if (!imu_initialization(&bg)) return fail(false);
  if (!observable()) return fail(true);
  // The loosely coupled BA, with the bias priors the tightly coupled window then keeps.
  Vector9 target = Vector9::Zero();
  target.segment<3>(state::kSbBg) = bg;
  Vector9 sigma = Vector9::Zero();
  sigma.segment<3>(state::kSbBg).setConstant(options_.init_bias_sigma_bg);
  sigma.segment<3>(state::kSbBa).setConstant(options_.init_bias_sigma_ba);
  builder_->set_init_prior(target, sigma, window_->at(0).id);
  marginalizer_->clear();
  SolveSpec spec;
  spec.groups = kAllGroups;
  spec.imu = true;
  spec.prior = false;
  constexpr int kAlignIterations = 8;
  if (!builder_->solve(spec, {kAlignIterations})) return fail(false);
  for (int k = 0; k < window_->size(); ++k)
    if (!Eigen::Map<const Vector9>(window_->at(k).sb).allFinite()) return fail(false);
  if (builder_->mark_outliers() > 0) landmarks_->compact();
  return ModeEvent::kAlignment;
}

bool Initializer::observable() {
  // Decided from the information the window has on gravity's direction (not from two solves
  // agreeing, which refuses whenever the second start does not converge in time).
  const int n = window_->size();
  Eigen::Quaterniond q[capacity::kWindowSize];
  const Preintegration* pre[capacity::kWindowSize];
  for (int k = 0; k < n; ++k) {
    WindowFrame& f = window_->at(k);
    q[k] = quat_of(f.pose).normalized();
    pre[k] = k > 0 && f.pre.num_samples() >= 2 ? &f.pre : nullptr;
  }
  AlignmentObservability obs;
  if (alignment_observability(q, pre, n, g_w_, options_.init_bias_sigma_ba, &obs) != Status::kOk) return false;
  stats_->align_tilt_sigma_deg = obs.tilt_sigma_rad * 180.0 / M_PI;
  // Rotation makes gravity's direction observable on its own; without it, an excited
  // accelerometer (the intervals' accelerations differ well beyond noise) still tests the
  // alignment's velocities against vision, and the tilt stays within the bias prior's bound.
  // Uniform motion has neither: the paper's case for staying in VO.
  return stats_->align_tilt_sigma_deg <= options_.align_max_tilt_sigma_deg ||
         obs.accel_excitation_m_s2 >= options_.align_min_excitation_m_s2;
}

bool Initializer::imu_initialization(Eigen::Vector3d* bg_out) {
  // Gyro bias from relative rotations, then gravity and velocities by least squares (stereo
  // fixes the scale); the world is then levelled to gravity.
  const int n = window_->size();
  Eigen::Quaterniond q[capacity::kWindowSize];
  Eigen::Vector3d p[capacity::kWindowSize];
  const Preintegration* pre[capacity::kWindowSize];
  for (int k = 0; k < n; ++k) {
    WindowFrame& f = window_->at(k);
    q[k] = quat_of(f.pose).normalized();
    p[k] = state::p(f.pose);
    pre[k] = k > 0 && f.pre.num_samples() >= 2 ? &f.pre : nullptr;
  }
  Eigen::Vector3d bg = Eigen::Vector3d::Zero();
  if (estimate_gyro_bias(q, pre, n, &bg) != Status::kOk || bg.norm() > 0.5) return false;
  for (int k = 1; k < n; ++k)
    if (pre[k] != nullptr) window_->at(k).pre.repropagate(Eigen::Vector3d::Zero(), bg);
  GravityVelocity gv;
  if (estimate_gravity_velocity(p, q, pre, n, Eigen::Vector3d::Zero(), bg, &gv) != Status::kOk) return false;
  if (std::abs(gv.g_w.norm() - options_.gravity_m_s2) > options_.max_gravity_error_m_s2) return false;
  const Eigen::Matrix3d R_fix = rotation_between(gv.g_w, -Eigen::Vector3d::UnitZ());
  for (int k = 0; k < n; ++k) {
    WindowFrame& f = window_->at(k);
    state::v(f.sb) = gv.v_w[k];
    state::ba(f.sb).setZero();
    state::bg(f.sb) = bg;
  }
  window_->rotate(R_fix, state::p(window_->newest().pose));
  window_->update_imu_factors(g_w_);
  *bg_out = bg;
  return true;
}

}  // namespace ums
