#include "core/imu/preintegration.hpp"

#include <algorithm>
#include <Eigen/Cholesky>
#include <cmath>
#include <stdexcept>
#include <string>

#include "core/math/so3.hpp"

namespace ums {
namespace {

bool finite(const ImuSample& s) { return s.gyro_rad_s.allFinite() && s.accel_m_s2.allFinite(); }

}  // namespace

void PreintegrationOptions::validate() const {
  noise.validate();
  if (!(repropagate_accel_bias_m_s2 > 0.0) || !std::isfinite(repropagate_accel_bias_m_s2)) {
    throw std::invalid_argument(
        "PreintegrationOptions.repropagate_accel_bias_m_s2 must be > 0, got " +
        std::to_string(repropagate_accel_bias_m_s2));
  }
  if (!(repropagate_gyro_bias_rad_s > 0.0) || !std::isfinite(repropagate_gyro_bias_rad_s)) {
    throw std::invalid_argument(
        "PreintegrationOptions.repropagate_gyro_bias_rad_s must be > 0, got " +
        std::to_string(repropagate_gyro_bias_rad_s));
  }
  if (max_samples < 2 || max_samples > capacity::kMaxImuSamplesBetweenFrames) {
    throw std::invalid_argument("PreintegrationOptions.max_samples must be in [2, " +
                                std::to_string(capacity::kMaxImuSamplesBetweenFrames) +
                                "] (capacity::kMaxImuSamplesBetweenFrames), got " +
                                std::to_string(max_samples));
  }
}

ImuSample interpolate_imu(const ImuSample& a, const ImuSample& b, std::int64_t t_ns) {
  ImuSample s;
  s.t_ns = t_ns;
  const double span = static_cast<double>(b.t_ns - a.t_ns);
  const double w = span > 0.0 ? static_cast<double>(t_ns - a.t_ns) / span : 0.0;
  s.gyro_rad_s = (1.0 - w) * a.gyro_rad_s + w * b.gyro_rad_s;
  s.accel_m_s2 = (1.0 - w) * a.accel_m_s2 + w * b.accel_m_s2;
  return s;
}

Preintegration::Preintegration(const PreintegrationOptions& options) : options_(options) {}

void Preintegration::clear_deltas() {
  alpha_.setZero();
  beta_.setZero();
  gamma_.setIdentity();
  covariance_.setZero();
  bias_jacobian_.setZero();
  // The error state at i depends on the bias at i through the bias rows only.
  bias_jacobian_.block<3, 3>(kBa, 0).setIdentity();
  bias_jacobian_.block<3, 3>(kBg, 3).setIdentity();
}

Status Preintegration::reset(const ImuSample& first, const Eigen::Vector3d& ba,
                             const Eigen::Vector3d& bg) {
  if (!finite(first) || !ba.allFinite() || !bg.allFinite()) return Status::kInvalidInput;
  samples_.clear();
  samples_.push_back(first);
  ba_ = ba;
  bg_ = bg;
  clear_deltas();
  unmodelled_ = UnmodelledMotion();
  return Status::kOk;
}

void Preintegration::add_unmodelled_motion(const UnmodelledMotion& u) {
  unmodelled_.var_theta_rad2 += std::max(0.0, u.var_theta_rad2);
  unmodelled_.var_v_m2_s2 += std::max(0.0, u.var_v_m2_s2);
  unmodelled_.lever_s = std::max(unmodelled_.lever_s, u.lever_s);
  unmodelled_.var_p_m2 += std::max(0.0, u.var_p_m2);
}

Status Preintegration::add(const ImuSample& sample) {
  if (samples_.empty()) return Status::kInvalidInput;  // reset() first
  if (!finite(sample) || sample.t_ns <= samples_.back().t_ns) return Status::kInvalidInput;
  if (samples_.size() >= options_.max_samples) return Status::kFull;
  const ImuSample prev = samples_.back();
  if (samples_.push_back(sample) != Status::kOk) return Status::kFull;
  step(prev, sample);
  return Status::kOk;
}

void Preintegration::step(const ImuSample& s0, const ImuSample& s1) {
  using Eigen::Matrix3d;
  using Eigen::Vector3d;
  const double dt = 1e-9 * static_cast<double>(s1.t_ns - s0.t_ns);
  const double dt2 = dt * dt;

  // Nominal midpoint step.
  const Vector3d a0 = s0.accel_m_s2 - ba_;
  const Vector3d a1 = s1.accel_m_s2 - ba_;
  const Vector3d w = 0.5 * (s0.gyro_rad_s + s1.gyro_rad_s) - bg_;
  const Vector3d dphi = w * dt;
  const Matrix3d R0 = gamma_.toRotationMatrix();
  const Eigen::Quaterniond q1 = (gamma_ * so3::exp_quat(dphi)).normalized();
  const Matrix3d R1 = q1.toRotationMatrix();
  const Vector3d acc = 0.5 * (R0 * a0 + R1 * a1);
  alpha_ += beta_ * dt + 0.5 * acc * dt2;
  beta_ += acc * dt;
  gamma_ = q1;

  // Error-state transition with right-perturbed rotation (gamma <- gamma Exp(dtheta)):
  //   dtheta1 = Exp(dphi)^T dtheta0 - Jr(dphi) dt (dbg + n_g),
  //   dacc    = -1/2 (R0 [a0]x dtheta0 + R1 [a1]x dtheta1) - 1/2 (R0 + R1) dba.
  // F = I except the blocks below (rows/cols alpha, theta, beta, ba, bg):
  //   alpha: [I, F_at, I dt, F_aba, F_abg]   theta: [0, F_tt, 0, 0, G]
  //   beta:  [0, F_vt, I,    F_vba, F_vbg]   ba, bg: identity rows.
  StepTransition f;
  f.dt_s = dt;
  f.F_tt = R1.transpose() * R0;           // Exp(dphi)^T
  f.G = -so3::right_jacobian(dphi) * dt;  // d dtheta1 / d(dbg or gyro noise)
  const Matrix3d A1 = -R1 * so3::hat(a1);
  const Matrix3d dacc_dth = 0.5 * (-R0 * so3::hat(a0) + A1 * f.F_tt);
  const Matrix3d dacc_dba = -0.5 * (R0 + R1);
  f.M = A1 * f.G;  // d acc / d(dbg), times 2
  const Matrix3d dacc_dbg = 0.5 * f.M;
  f.F_at = 0.5 * dt2 * dacc_dth;
  f.F_aba = 0.5 * dt2 * dacc_dba;
  f.F_abg = 0.5 * dt2 * dacc_dbg;
  f.F_vt = dt * dacc_dth;
  f.F_vba = dt * dacc_dba;
  f.F_vbg = dt * dacc_dbg;

  propagate_covariance(f);
  add_step_noise(f);
  propagate_bias_jacobian(f);
}

// P <- F P F^T using the block structure (about a third of the dense cost).
void Preintegration::propagate_covariance(const StepTransition& f) {
  const double dt = f.dt_s;
  Matrix15& P = covariance_;
  Matrix15 FP;
  FP.middleRows<3>(kP).noalias() = P.middleRows<3>(kP) + dt * P.middleRows<3>(kV);
  FP.middleRows<3>(kP).noalias() += f.F_at * P.middleRows<3>(kTheta);
  FP.middleRows<3>(kP).noalias() += f.F_aba * P.middleRows<3>(kBa);
  FP.middleRows<3>(kP).noalias() += f.F_abg * P.middleRows<3>(kBg);
  FP.middleRows<3>(kTheta).noalias() = f.F_tt * P.middleRows<3>(kTheta);
  FP.middleRows<3>(kTheta).noalias() += f.G * P.middleRows<3>(kBg);
  FP.middleRows<3>(kV) = P.middleRows<3>(kV);
  FP.middleRows<3>(kV).noalias() += f.F_vt * P.middleRows<3>(kTheta);
  FP.middleRows<3>(kV).noalias() += f.F_vba * P.middleRows<3>(kBa);
  FP.middleRows<3>(kV).noalias() += f.F_vbg * P.middleRows<3>(kBg);
  FP.middleRows<6>(kBa) = P.middleRows<6>(kBa);
  P.middleCols<3>(kP).noalias() = FP.middleCols<3>(kP) + dt * FP.middleCols<3>(kV);
  P.middleCols<3>(kP).noalias() += FP.middleCols<3>(kTheta) * f.F_at.transpose();
  P.middleCols<3>(kP).noalias() += FP.middleCols<3>(kBa) * f.F_aba.transpose();
  P.middleCols<3>(kP).noalias() += FP.middleCols<3>(kBg) * f.F_abg.transpose();
  P.middleCols<3>(kTheta).noalias() = FP.middleCols<3>(kTheta) * f.F_tt.transpose();
  P.middleCols<3>(kTheta).noalias() += FP.middleCols<3>(kBg) * f.G.transpose();
  P.middleCols<3>(kV) = FP.middleCols<3>(kV);
  P.middleCols<3>(kV).noalias() += FP.middleCols<3>(kTheta) * f.F_vt.transpose();
  P.middleCols<3>(kV).noalias() += FP.middleCols<3>(kBa) * f.F_vba.transpose();
  P.middleCols<3>(kV).noalias() += FP.middleCols<3>(kBg) * f.F_vbg.transpose();
  P.middleCols<6>(kBa) = FP.middleCols<6>(kBa);
}

// Noise. The midpoint uses the noise of both end samples, which every step shares with its
// neighbour; treating them as independent halves the variance, so each end sample gets
// 2 sigma^2/dt and the accumulated rotation variance is the continuous sigma_g^2 * T.
// Inputs n_a0, n_a1 (var_a each) and n_g = (n_g0 + n_g1)/2 (var_g) enter as
//   dalpha += dt^2/4 (R0 n_a0 + R1 n_a1 + M n_g),  dtheta += G n_g,
//   dbeta  += dt/2   (R0 n_a0 + R1 n_a1 + M n_g);   R R^T = I gives the closed form below.
void Preintegration::add_step_noise(const StepTransition& f) {
  using Eigen::Matrix3d;
  const double dt = f.dt_s;
  const double dt2 = dt * dt;
  Matrix15& P = covariance_;
  const ImuNoise& n = options_.noise;
  const double var_a = 2.0 * n.accel_noise_density * n.accel_noise_density / dt;
  const double var_g = n.gyro_noise_density * n.gyro_noise_density / dt;
  const double ca = 0.25 * dt2, cv = 0.5 * dt;
  const Matrix3d MMt = var_g * f.M * f.M.transpose();
  const Matrix3d GGt = var_g * f.G * f.G.transpose();
  const Matrix3d MGt = var_g * f.M * f.G.transpose();
  const Matrix3d I3 = Matrix3d::Identity();
  const Matrix3d Q_aa = ca * ca * (2.0 * var_a * I3 + MMt);
  const Matrix3d Q_av = ca * cv * (2.0 * var_a * I3 + MMt);
  const Matrix3d Q_vv = cv * cv * (2.0 * var_a * I3 + MMt);
  P.block<3, 3>(kP, kP) += Q_aa;
  P.block<3, 3>(kP, kTheta) += ca * MGt;
  P.block<3, 3>(kTheta, kP) += ca * MGt.transpose();
  P.block<3, 3>(kP, kV) += Q_av;
  P.block<3, 3>(kV, kP) += Q_av.transpose();
  P.block<3, 3>(kTheta, kTheta) += GGt;
  P.block<3, 3>(kTheta, kV) += cv * MGt.transpose();
  P.block<3, 3>(kV, kTheta) += cv * MGt;
  P.block<3, 3>(kV, kV) += Q_vv;
  P.block<3, 3>(kBa, kBa).diagonal().array() += n.accel_random_walk * n.accel_random_walk * dt;
  P.block<3, 3>(kBg, kBg).diagonal().array() += n.gyro_random_walk * n.gyro_random_walk * dt;
}

// Bias Jacobian: its ba/bg rows stay [I 0; 0 I], so only the alpha/theta/beta rows move.
void Preintegration::propagate_bias_jacobian(const StepTransition& f) {
  const double dt = f.dt_s;
  Eigen::Matrix<double, 3, 6> J_a = bias_jacobian_.middleRows<3>(kP);
  const Eigen::Matrix<double, 3, 6> J_t = bias_jacobian_.middleRows<3>(kTheta);
  Eigen::Matrix<double, 3, 6> J_v = bias_jacobian_.middleRows<3>(kV);
  J_a.noalias() += dt * J_v;
  J_a.noalias() += f.F_at * J_t;
  J_a.leftCols<3>() += f.F_aba;
  J_a.rightCols<3>() += f.F_abg;
  J_v.noalias() += f.F_vt * J_t;
  J_v.leftCols<3>() += f.F_vba;
  J_v.rightCols<3>() += f.F_vbg;
  bias_jacobian_.middleRows<3>(kP) = J_a;
  bias_jacobian_.middleRows<3>(kTheta).noalias() = f.F_tt * J_t;
  bias_jacobian_.middleRows<3>(kTheta).rightCols<3>() += f.G;
  bias_jacobian_.middleRows<3>(kV) = J_v;
}

void Preintegration::repropagate(const Eigen::Vector3d& ba, const Eigen::Vector3d& bg) {
  ba_ = ba;
  bg_ = bg;
  clear_deltas();
  for (std::size_t k = 1; k < samples_.size(); ++k) step(samples_[k - 1], samples_[k]);
  ++repropagations_;
}

bool Preintegration::needs_repropagation(const Eigen::Vector3d& ba,
                                         const Eigen::Vector3d& bg) const {
  return (ba - ba_).cwiseAbs().maxCoeff() > options_.repropagate_accel_bias_m_s2 ||
         (bg - bg_).cwiseAbs().maxCoeff() > options_.repropagate_gyro_bias_rad_s;
}

bool Preintegration::repropagate_if_needed(const Eigen::Vector3d& ba, const Eigen::Vector3d& bg) {
  if (!needs_repropagation(ba, bg)) return false;
  repropagate(ba, bg);
  return true;
}

void Preintegration::corrected(const Eigen::Vector3d& ba, const Eigen::Vector3d& bg,
                               Eigen::Vector3d* alpha, Eigen::Vector3d* beta,
                               Eigen::Quaterniond* gamma) const {
  const Eigen::Vector3d dba = ba - ba_;
  const Eigen::Vector3d dbg = bg - bg_;
  if (alpha) *alpha = alpha_ + d_alpha_d_ba() * dba + d_alpha_d_bg() * dbg;
  if (beta) *beta = beta_ + d_beta_d_ba() * dba + d_beta_d_bg() * dbg;
  if (gamma) *gamma = (gamma_ * so3::exp_quat(d_gamma_d_bg() * dbg)).normalized();
}

Status Preintegration::sqrt_information(Matrix15* U) const {
  return sqrt_information_of(whitened_covariance(), U);
}

Preintegration::Matrix15 Preintegration::whitened_covariance() const {
  // Symmetrise first: F P F^T accumulates rounding asymmetry.
  Matrix15 P = 0.5 * (covariance_ + covariance_.transpose());
  if (has_unmodelled_motion()) {
    const double l = unmodelled_.lever_s, var_v = unmodelled_.var_v_m2_s2;
    const Eigen::Matrix3d I = Eigen::Matrix3d::Identity();
    P.block<3, 3>(kTheta, kTheta) += unmodelled_.var_theta_rad2 * I;
    P.block<3, 3>(kV, kV) += var_v * I;
    P.block<3, 3>(kP, kP) += (l * l * var_v + unmodelled_.var_p_m2) * I;
    P.block<3, 3>(kP, kV) += l * var_v * I;
    P.block<3, 3>(kV, kP) += l * var_v * I;
  }
  return P;
}

Status Preintegration::sqrt_information_of(const Matrix15& P, Matrix15* U) {
  Eigen::LLT<Matrix15> llt_p(P);
  if (llt_p.info() != Eigen::Success) return Status::kSingular;
  Matrix15 info = llt_p.solve(Matrix15::Identity());
  info = 0.5 * (info + info.transpose()).eval();
  Eigen::LLT<Matrix15> llt_i(info);
  if (llt_i.info() != Eigen::Success) return Status::kSingular;
  *U = llt_i.matrixU();
  return U->allFinite() ? Status::kOk : Status::kSingular;
}

}  // namespace ums
