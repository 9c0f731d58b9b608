#include "core/imu/imu_residual.hpp"

#include <Eigen/Geometry>

#include "core/math/quaternion.hpp"
#include "core/math/so3.hpp"

namespace ums {
namespace {

constexpr int kP = Preintegration::kP;
constexpr int kTh = Preintegration::kTheta;
constexpr int kV = Preintegration::kV;
constexpr int kBa = Preintegration::kBa;
constexpr int kBg = Preintegration::kBg;

struct State {
  Eigen::Vector3d p;
  Eigen::Quaterniond q;
  Eigen::Vector3d v, ba, bg;
};

State read(const double* pose, const double* speedbias) {
  State s;
  s.p = Eigen::Map<const Eigen::Vector3d>(pose);
  s.q = Eigen::Map<const Eigen::Quaterniond>(pose + 3);  // memory (x, y, z, w)
  s.q.normalize();
  s.v = Eigen::Map<const Eigen::Vector3d>(speedbias);
  s.ba = Eigen::Map<const Eigen::Vector3d>(speedbias + 3);
  s.bg = Eigen::Map<const Eigen::Vector3d>(speedbias + 6);
  return s;
}

// The quantities the residual and every Jacobian block share (paper eq. (1), imu_residual.hpp).
struct Terms {
  State si, sj;
  double dt = 0.0;
  Eigen::Vector3d alpha, beta;  // bias-corrected deltas at the biases of i
  Eigen::Quaterniond gamma;
  Eigen::Matrix3d Ri_T;
  Eigen::Vector3d x_p, x_v;
  Eigen::Quaterniond qij, e;  // q_i^-1 q_j; gamma~^-1 q_ij with w >= 0
  double sign = 1.0;          // the sign that made e.w() >= 0
};

Terms terms_of(const Preintegration& pre, const Eigen::Vector3d& g_w, const double* pose_i,
               const double* speedbias_i, const double* pose_j, const double* speedbias_j) {
  Terms t;
  t.si = read(pose_i, speedbias_i);
  t.sj = read(pose_j, speedbias_j);
  t.dt = pre.dt_s();
  const double dt = t.dt;
  pre.corrected(t.si.ba, t.si.bg, &t.alpha, &t.beta, &t.gamma);
  t.Ri_T = t.si.q.toRotationMatrix().transpose();
  t.x_p = t.sj.p - t.si.p - t.si.v * dt - 0.5 * g_w * dt * dt;
  t.x_v = t.sj.v - t.si.v - g_w * dt;
  t.qij = t.si.q.conjugate() * t.sj.q;
  t.e = t.gamma.conjugate() * t.qij;
  // q and -q are the same rotation; with w >= 0 the residual is the small-angle one.
  t.sign = t.e.w() < 0.0 ? -1.0 : 1.0;
  t.e.coeffs() *= t.sign;
  return t;
}

// Whitening U J exploits the zero row blocks of each raw Jacobian.
void jacobian_pose_i(const Terms& t, const Preintegration::Matrix15& U, double* out) {
  // Rows alpha, theta, beta only.
  Eigen::Matrix<double, 9, 6> J = Eigen::Matrix<double, 9, 6>::Zero();
  J.block<3, 3>(kP, 0) = -t.Ri_T;
  J.block<3, 3>(kP, 3) = so3::hat(t.Ri_T * t.x_p);
  // e(dtheta) = gamma~^-1 Exp(-dtheta) qij  ->  d(2 vec e) = -[L(gamma~^-1) R(qij)]_vec,vec
  const Eigen::Matrix4d LR = quat::left(t.gamma.conjugate()) * quat::right(t.qij);
  J.block<3, 3>(kTh, 3) = -t.sign * LR.block<3, 3>(1, 1);
  J.block<3, 3>(kV, 3) = so3::hat(t.Ri_T * t.x_v);
  Eigen::Map<ImuResidual::JacobianPose>(out).noalias() = U.leftCols<9>() * J;
}

void jacobian_speedbias_i(const Terms& t, const Preintegration& pre, const Preintegration::Matrix15& U,
                          double* out) {
  // The gamma correction is Exp(J dbg): its derivative carries Jr of that small angle.
  const Eigen::Vector3d phi_bg = pre.d_gamma_d_bg() * (t.si.bg - pre.linearization_bg());
  const Eigen::Matrix3d I3 = Eigen::Matrix3d::Identity();
  // Rows alpha, theta, beta here; the bias rows are -I, added column-wise below.
  Eigen::Matrix<double, 9, 9> J = Eigen::Matrix<double, 9, 9>::Zero();
  J.block<3, 3>(kP, 0) = -t.Ri_T * t.dt;
  J.block<3, 3>(kP, 3) = -pre.d_alpha_d_ba();
  J.block<3, 3>(kP, 6) = -pre.d_alpha_d_bg();
  // e(dbg) = Exp(-Jr(phi) J_gamma_bg dbg) e  ->  d(2 vec e) = -[R(e)]_vec,vec Jr(phi) J_gamma_bg
  J.block<3, 3>(kTh, 6) =
      -(t.e.w() * I3 - so3::hat(t.e.vec())) * so3::right_jacobian(phi_bg) * pre.d_gamma_d_bg();
  J.block<3, 3>(kV, 0) = -t.Ri_T;
  J.block<3, 3>(kV, 3) = -pre.d_beta_d_ba();
  J.block<3, 3>(kV, 6) = -pre.d_beta_d_bg();
  Eigen::Map<ImuResidual::JacobianSpeedBias> out_j(out);
  out_j.noalias() = U.leftCols<9>() * J;
  out_j.middleCols<3>(3) -= U.middleCols<3>(kBa);
  out_j.middleCols<3>(6) -= U.middleCols<3>(kBg);
}

void jacobians_j(const Terms& t, const Preintegration::Matrix15& U, double* d_pose_j, double* d_speedbias_j) {
  if (d_pose_j) {
    // Rows alpha and theta only: alpha wrt dp is R_i^T, theta wrt dtheta is
    // e(dtheta) = e Exp(dtheta)  ->  d(2 vec e) = [L(e)]_vec,vec = w I + [vec]x.
    Eigen::Map<ImuResidual::JacobianPose> out_j(d_pose_j);
    out_j.leftCols<3>().noalias() = U.middleCols<3>(kP) * t.Ri_T;
    out_j.rightCols<3>().noalias() =
        U.middleCols<3>(kTh) * (t.e.w() * Eigen::Matrix3d::Identity() + so3::hat(t.e.vec()));
  }
  if (d_speedbias_j) {
    Eigen::Map<ImuResidual::JacobianSpeedBias> out_j(d_speedbias_j);
    out_j.leftCols<3>().noalias() = U.middleCols<3>(kV) * t.Ri_T;
    out_j.middleCols<3>(3) = U.middleCols<3>(kBa);
    out_j.middleCols<3>(6) = U.middleCols<3>(kBg);
  }
}

}  // namespace

Status ImuResidual::init(const Preintegration* preintegration, const Eigen::Vector3d& g_w) {
  pre_ = preintegration;
  g_w_ = g_w;
  return update_whitening();
}

Status ImuResidual::update_whitening() {
  if (pre_ == nullptr) return Status::kInvalidInput;
  // Two 15 x 15 factorizations and an inverse (about 57 k instructions) against 225 compares.
  const Preintegration::Matrix15 P = pre_->whitened_covariance();
  if (whitened_ && P == whitened_covariance_) return Status::kOk;
  whitened_ = false;
  const Status s = Preintegration::sqrt_information_of(P, &sqrt_information_);
  if (s == Status::kOk) {
    whitened_covariance_ = P;
    whitened_ = true;
  }
  return s;
}

ImuResidual::Vector15 ImuResidual::raw_residual(const double* pose_i, const double* speedbias_i,
                                                const double* pose_j,
                                                const double* speedbias_j) const {
  Vector15 r;
  evaluate(pose_i, speedbias_i, pose_j, speedbias_j, r.data(), nullptr, nullptr, nullptr, nullptr);
  // evaluate() whitens; undo it with a triangular solve (tests/diagnostics only).
  return sqrt_information_.triangularView<Eigen::Upper>().solve(r);
}

bool ImuResidual::evaluate(const double* pose_i, const double* speedbias_i, const double* pose_j,
                           const double* speedbias_j, double* residual, double* d_r_d_pose_i,
                           double* d_r_d_speedbias_i, double* d_r_d_pose_j,
                           double* d_r_d_speedbias_j) const {
  const Terms t = terms_of(*pre_, g_w_, pose_i, speedbias_i, pose_j, speedbias_j);
  Vector15 r;
  r.segment<3>(kP) = t.Ri_T * t.x_p - t.alpha;
  r.segment<3>(kTh) = 2.0 * t.e.vec();
  r.segment<3>(kV) = t.Ri_T * t.x_v - t.beta;
  r.segment<3>(kBa) = t.sj.ba - t.si.ba;
  r.segment<3>(kBg) = t.sj.bg - t.si.bg;

  Eigen::Map<Vector15> out(residual);
  out.noalias() = sqrt_information_ * r;
  if (!out.allFinite()) return false;
  if (d_r_d_pose_i) jacobian_pose_i(t, sqrt_information_, d_r_d_pose_i);
  if (d_r_d_speedbias_i) jacobian_speedbias_i(t, *pre_, sqrt_information_, d_r_d_speedbias_i);
  jacobians_j(t, sqrt_information_, d_r_d_pose_j, d_r_d_speedbias_j);
  return true;
}

}  // namespace ums
