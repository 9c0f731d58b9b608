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
  using Eigen::Matrix3d;
  using Eigen::Vector3d;
  const State si = read(pose_i, speedbias_i);
  const State sj = read(pose_j, speedbias_j);
  const double dt = pre_->dt_s();

  Vector3d alpha, beta;
  Eigen::Quaterniond gamma;
  pre_->corrected(si.ba, si.bg, &alpha, &beta, &gamma);

  const Matrix3d Ri_T = si.q.toRotationMatrix().transpose();
  const Vector3d x_p = sj.p - si.p - si.v * dt - 0.5 * g_w_ * dt * dt;
  const Vector3d x_v = sj.v - si.v - g_w_ * dt;
  const Eigen::Quaterniond qij = si.q.conjugate() * sj.q;
  Eigen::Quaterniond e = gamma.conjugate() * qij;
  // q and -q are the same rotation; with w >= 0 the residual is the small-angle one.
  const double sign = e.w() < 0.0 ? -1.0 : 1.0;
  e.coeffs() *= sign;

  Vector15 r;
  r.segment<3>(kP) = Ri_T * x_p - alpha;
  r.segment<3>(kTh) = 2.0 * e.vec();
  r.segment<3>(kV) = Ri_T * x_v - beta;
  r.segment<3>(kBa) = sj.ba - si.ba;
  r.segment<3>(kBg) = sj.bg - si.bg;

  Eigen::Map<Vector15> out(residual);
  out.noalias() = sqrt_information_ * r;
  if (!out.allFinite()) return false;

  // The gamma correction is Exp(J dbg): its derivative carries Jr of that small angle.
  const Vector3d phi_bg = pre_->d_gamma_d_bg() * (si.bg - pre_->linearization_bg());
  const Matrix3d I3 = Matrix3d::Identity();

  // Whitening U J exploits the zero row blocks of each raw Jacobian.
  const Preintegration::Matrix15& U = sqrt_information_;
  if (d_r_d_pose_i) {
    // Rows alpha, theta, beta only.
    Eigen::Matrix<double, 9, 6> J = Eigen::Matrix<double, 9, 6>::Zero();
    J.block<3, 3>(kP, 0) = -Ri_T;
    J.block<3, 3>(kP, 3) = so3::hat(Ri_T * x_p);
    // e(dtheta) = gamma~^-1 Exp(-dtheta) qij  ->  d(2 vec e) = -[L(gamma~^-1) R(qij)]_vec,vec
    const Eigen::Matrix4d LR = quat::left(gamma.conjugate()) * quat::right(qij);
    J.block<3, 3>(kTh, 3) = -sign * LR.block<3, 3>(1, 1);
    J.block<3, 3>(kV, 3) = so3::hat(Ri_T * x_v);
    Eigen::Map<JacobianPose>(d_r_d_pose_i).noalias() = U.leftCols<9>() * J;
  }
  if (d_r_d_speedbias_i) {
    // Rows alpha, theta, beta here; the bias rows are -I, added column-wise below.
    Eigen::Matrix<double, 9, 9> J = Eigen::Matrix<double, 9, 9>::Zero();
    J.block<3, 3>(kP, 0) = -Ri_T * dt;
    J.block<3, 3>(kP, 3) = -pre_->d_alpha_d_ba();
    J.block<3, 3>(kP, 6) = -pre_->d_alpha_d_bg();
    // e(dbg) = Exp(-Jr(phi) J_gamma_bg dbg) e  ->  d(2 vec e) = -[R(e)]_vec,vec Jr(phi) J_gamma_bg
    J.block<3, 3>(kTh, 6) =
        -(e.w() * I3 - so3::hat(e.vec())) * so3::right_jacobian(phi_bg) * pre_->d_gamma_d_bg();
    J.block<3, 3>(kV, 0) = -Ri_T;
    J.block<3, 3>(kV, 3) = -pre_->d_beta_d_ba();
    J.block<3, 3>(kV, 6) = -pre_->d_beta_d_bg();
    Eigen::Map<JacobianSpeedBias> out_j(d_r_d_speedbias_i);
    out_j.noalias() = U.leftCols<9>() * J;
    out_j.middleCols<3>(3) -= U.middleCols<3>(kBa);
    out_j.middleCols<3>(6) -= U.middleCols<3>(kBg);
  }
  if (d_r_d_pose_j) {
    // Rows alpha and theta only: alpha wrt dp is R_i^T, theta wrt dtheta is
    // e(dtheta) = e Exp(dtheta)  ->  d(2 vec e) = [L(e)]_vec,vec = w I + [vec]x.
    Eigen::Map<JacobianPose> out_j(d_r_d_pose_j);
    out_j.leftCols<3>().noalias() = U.middleCols<3>(kP) * Ri_T;
    out_j.rightCols<3>().noalias() = U.middleCols<3>(kTh) * (e.w() * I3 + so3::hat(e.vec()));
  }
  if (d_r_d_speedbias_j) {
    Eigen::Map<JacobianSpeedBias> out_j(d_r_d_speedbias_j);
    out_j.leftCols<3>().noalias() = U.middleCols<3>(kV) * Ri_T;
    out_j.middleCols<3>(3) = U.middleCols<3>(kBa);
    out_j.middleCols<3>(6) = U.middleCols<3>(kBg);
  }
  return true;
}

}  // namespace ums
