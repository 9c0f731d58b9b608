#include "core/estimator/imu_alignment.hpp"

#include <cmath>

#include <Eigen/Cholesky>

#include "core/math/so3.hpp"

namespace ums {

Status estimate_gyro_bias(const Eigen::Quaterniond* q_w_b, const Preintegration* const* pre, int n,
                          Eigen::Vector3d* bg) {
  Eigen::Matrix3d A = Eigen::Matrix3d::Zero();
  Eigen::Vector3d b = Eigen::Vector3d::Zero();
  int used = 0;
  Eigen::Vector3d bg_lin = Eigen::Vector3d::Zero();
  for (int k = 1; k < n; ++k) {
    if (pre[k] == nullptr || pre[k]->num_samples() < 2) continue;
    const Preintegration& p = *pre[k];
    bg_lin = p.linearization_bg();
    const Eigen::Quaterniond q_ij = q_w_b[k - 1].conjugate() * q_w_b[k];
    // gamma Exp(J dbg) = q_ij  ->  J dbg = Log(gamma^-1 q_ij)
    const Eigen::Vector3d y = so3::log(Eigen::Quaterniond(p.gamma().conjugate() * q_ij));
    const Eigen::Matrix3d J = p.d_gamma_d_bg();
    A += J.transpose() * J;
    b += J.transpose() * y;
    ++used;
  }
  if (used < 2) return Status::kNotEnoughData;
  const Eigen::LDLT<Eigen::Matrix3d> ldlt(A);
  if (ldlt.info() != Eigen::Success || A.determinant() < 1e-12) return Status::kSingular;
  *bg = bg_lin + ldlt.solve(b);
  return bg->allFinite() ? Status::kOk : Status::kSingular;
}

namespace {

// Residual RMS of the position equations (m) at the fitted velocities and gravity: the quality
// measure of the fit. R_alpha, dt_s: per interval, as the fit used them.
double position_rms_m(const Eigen::Vector3d* p_w_b, const Preintegration* const* pre, int n,
                      const Eigen::Vector3d* R_alpha, const double* dt_s, const GravityVelocity& fit) {
  double sum = 0.0;
  int rows = 0;
  for (int k = 1; k < n; ++k) {
    if (pre[k] == nullptr || pre[k]->num_samples() < 2) continue;
    const double dt = dt_s[k];
    const Eigen::Vector3d e =
        p_w_b[k - 1] + fit.v_w[k - 1] * dt + 0.5 * fit.g_w * dt * dt + R_alpha[k] - p_w_b[k];
    sum += e.squaredNorm();
    rows += 3;
  }
  return std::sqrt(sum / std::max(rows, 1));
}

}  // namespace

Status estimate_gravity_velocity(const Eigen::Vector3d* p_w_b, const Eigen::Quaterniond* q_w_b,
                                 const Preintegration* const* pre, int n, const Eigen::Vector3d& ba,
                                 const Eigen::Vector3d& bg, GravityVelocity* out) {
  constexpr int kMaxFrames = 16;
  constexpr int kMaxDim = 3 * kMaxFrames + 3;
  if (n < 3 || n > kMaxFrames) return Status::kNotEnoughData;
  const int dim = 3 * n + 3;
  const int ig = 3 * n;
  Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, 0, kMaxDim, kMaxDim> H(dim, dim);
  Eigen::Matrix<double, Eigen::Dynamic, 1, 0, kMaxDim, 1> rhs(dim);
  H.setZero();
  rhs.setZero();
  // Per interval, kept for the fit's residual below: the rotated position delta and dt.
  Eigen::Vector3d R_alpha[kMaxFrames];
  double dt_s[kMaxFrames] = {};
  int used = 0;
  for (int k = 1; k < n; ++k) {
    if (pre[k] == nullptr || pre[k]->num_samples() < 2) continue;
    Eigen::Vector3d alpha, beta;
    Eigen::Quaterniond gamma;
    pre[k]->corrected(ba, bg, &alpha, &beta, &gamma);
    const double dt = pre[k]->dt_s();
    const Eigen::Matrix3d R_i = q_w_b[k - 1].toRotationMatrix();
    // Rows: [v_i, v_j, g] coefficients.
    Eigen::Matrix<double, 6, 9> J = Eigen::Matrix<double, 6, 9>::Zero();
    Eigen::Matrix<double, 6, 1> y;
    J.block<3, 3>(0, 0) = dt * Eigen::Matrix3d::Identity();
    J.block<3, 3>(0, 6) = 0.5 * dt * dt * Eigen::Matrix3d::Identity();
    R_alpha[k] = R_i * alpha;
    dt_s[k] = dt;
    y.head<3>() = p_w_b[k] - p_w_b[k - 1] - R_alpha[k];
    J.block<3, 3>(3, 0) = -Eigen::Matrix3d::Identity();
    J.block<3, 3>(3, 3) = Eigen::Matrix3d::Identity();
    J.block<3, 3>(3, 6) = -dt * Eigen::Matrix3d::Identity();
    y.tail<3>() = R_i * beta;
    const int cols[3] = {3 * (k - 1), 3 * k, ig};
    const Eigen::Matrix<double, 9, 9> JtJ = J.transpose() * J;
    const Eigen::Matrix<double, 9, 1> Jty = J.transpose() * y;
    for (int a = 0; a < 3; ++a) {
      rhs.segment<3>(cols[a]) += Jty.segment<3>(3 * a);
      for (int c = 0; c < 3; ++c) H.block<3, 3>(cols[a], cols[c]) += JtJ.block<3, 3>(3 * a, 3 * c);
    }
    ++used;
  }
  if (used < 2) return Status::kNotEnoughData;
  const Eigen::LDLT<Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, 0, kMaxDim, kMaxDim>> ldlt(H);
  if (ldlt.info() != Eigen::Success) return Status::kSingular;
  const Eigen::Matrix<double, Eigen::Dynamic, 1, 0, kMaxDim, 1> x = ldlt.solve(rhs);
  if (!x.allFinite()) return Status::kSingular;
  for (int k = 0; k < n; ++k) out->v_w[k] = x.segment<3>(3 * k);
  out->g_w = x.segment<3>(ig);
  out->rms_m = position_rms_m(p_w_b, pre, n, R_alpha, dt_s, *out);
  return Status::kOk;
}

}  // namespace ums
