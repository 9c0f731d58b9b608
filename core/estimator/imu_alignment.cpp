#include "core/estimator/imu_alignment.hpp"

#include <cmath>

#include <Eigen/Cholesky>
#include <Eigen/Eigenvalues>

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

namespace {

// Weight of one interval's [alpha; beta] equations: the inverse of their preintegrated covariance.
bool alpha_beta_information(const Preintegration& p, Eigen::Matrix<double, 6, 6>* W) {
  constexpr int kA = Preintegration::kP, kB = Preintegration::kV;
  const Preintegration::Matrix15& C = p.covariance();
  Eigen::Matrix<double, 6, 6> S;
  S << C.block<3, 3>(kA, kA), C.block<3, 3>(kA, kB), C.block<3, 3>(kB, kA), C.block<3, 3>(kB, kB);
  const Eigen::LDLT<Eigen::Matrix<double, 6, 6>> ldlt(S);
  if (ldlt.info() != Eigen::Success || !(ldlt.vectorD().minCoeff() > 0.0)) return false;
  *W = ldlt.solve(Eigen::Matrix<double, 6, 6>::Identity());
  return W->allFinite();
}

double accel_excitation_m_s2(const Eigen::Quaterniond* q_w_b, const Preintegration* const* pre, int n,
                             const Eigen::Vector3d& g_w) {
  Eigen::Vector3d a_w[16];
  int m = 0;
  Eigen::Vector3d mean = Eigen::Vector3d::Zero();
  for (int k = 1; k < n && m < 16; ++k) {
    if (pre[k] == nullptr || pre[k]->num_samples() < 2 || !(pre[k]->dt_s() > 0.0)) continue;
    a_w[m] = q_w_b[k - 1] * pre[k]->beta() / pre[k]->dt_s() + g_w;
    mean += a_w[m++];
  }
  if (m < 2) return 0.0;
  mean /= m;
  double sum = 0.0;
  for (int k = 0; k < m; ++k) sum += (a_w[k] - mean).squaredNorm();
  return std::sqrt(sum / m);
}

double largest_sigma(const Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, 0, 5, 5>& C) {
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, 0, 5, 5>> es(
      C, Eigen::EigenvaluesOnly);
  return std::sqrt(std::max(0.0, es.eigenvalues().maxCoeff()));
}

}  // namespace

Status alignment_observability(const Eigen::Quaterniond* q_w_b, const Preintegration* const* pre, int n,
                               const Eigen::Vector3d& g_w, double ba_prior_sigma_m_s2,
                               AlignmentObservability* out) {
  constexpr int kMaxFrames = 16;
  constexpr int kMaxDim = 3 * kMaxFrames + 5;
  if (n < 2 || n > kMaxFrames || !(ba_prior_sigma_m_s2 > 0.0)) return Status::kNotEnoughData;
  const int dim = 3 * n + 5, it = 3 * n, ib = 3 * n + 2;
  Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, 0, kMaxDim, kMaxDim> H(dim, dim);
  H.setZero();
  H.block<3, 3>(ib, ib) = Eigen::Matrix3d::Identity() / (ba_prior_sigma_m_s2 * ba_prior_sigma_m_s2);
  // d g_w / d tilt for a small world rotation about x and y: -[g_w]x, its first two columns.
  Eigen::Matrix3d g_hat;
  g_hat << 0.0, -g_w.z(), g_w.y(), g_w.z(), 0.0, -g_w.x(), -g_w.y(), g_w.x(), 0.0;
  const Eigen::Matrix<double, 3, 2> dg_dtilt = -g_hat.leftCols<2>();
  int used = 0;
  for (int k = 1; k < n; ++k) {
    if (pre[k] == nullptr || pre[k]->num_samples() < 2) continue;
    Eigen::Matrix<double, 6, 6> W;
    if (!alpha_beta_information(*pre[k], &W)) continue;
    const double dt = pre[k]->dt_s();
    const Eigen::Matrix3d Rt = q_w_b[k - 1].toRotationMatrix().transpose();
    // r_alpha = R_i^T (p_j - p_i - v_i dt - 1/2 g dt^2) - alpha(ba), r_beta = R_i^T (v_j - v_i - g dt) - beta(ba):
    // columns [v_i (3), v_j (3), tilt (2), ba (3)].
    Eigen::Matrix<double, 6, 11> J = Eigen::Matrix<double, 6, 11>::Zero();
    J.block<3, 3>(0, 0) = -dt * Rt;
    J.block<3, 2>(0, 6) = -0.5 * dt * dt * Rt * dg_dtilt;
    J.block<3, 3>(0, 8) = -pre[k]->d_alpha_d_ba();
    J.block<3, 3>(3, 0) = -Rt;
    J.block<3, 3>(3, 3) = Rt;
    J.block<3, 2>(3, 6) = -dt * Rt * dg_dtilt;
    J.block<3, 3>(3, 8) = -pre[k]->d_beta_d_ba();
    const Eigen::Matrix<double, 11, 11> JtWJ = J.transpose() * W * J;
    const int col[4] = {3 * (k - 1), 3 * k, it, ib};
    const int width[4] = {3, 3, 2, 3}, off[4] = {0, 3, 6, 8};
    for (int a = 0; a < 4; ++a)
      for (int c = 0; c < 4; ++c)
        H.block(col[a], col[c], width[a], width[c]) += JtWJ.block(off[a], off[c], width[a], width[c]);
    ++used;
  }
  if (used < 2) return Status::kNotEnoughData;
  // Frames without a usable interval have no information on their velocity: pin them.
  for (int i = 0; i < 3 * n; ++i)
    if (H(i, i) == 0.0) H(i, i) = 1.0;
  const Eigen::LDLT<Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, 0, kMaxDim, kMaxDim>> ldlt(H);
  if (ldlt.info() != Eigen::Success || !(ldlt.vectorD().minCoeff() > 0.0)) return Status::kSingular;
  Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, 0, kMaxDim, 5> E(dim, 5);
  E.setZero();
  E.bottomRows<5>().setIdentity();
  const Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, 0, 5, 5> C = (E.transpose() * ldlt.solve(E)).eval();
  if (!C.allFinite()) return Status::kSingular;
  out->tilt_sigma_rad = largest_sigma(C.topLeftCorner(2, 2));
  out->ba_sigma_m_s2 = largest_sigma(C.bottomRightCorner(3, 3));
  out->accel_excitation_m_s2 = accel_excitation_m_s2(q_w_b, pre, n, g_w);
  return Status::kOk;
}

}  // namespace ums
