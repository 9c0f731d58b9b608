#pragma once
// VIO-shaped residuals for the solver benchmark and the solver tests: the same code is evaluated by
// our solver and (through thin adapters) by Ceres, so the two solve the identical problem.
// They follow the product's conventions (../shared notes "conventions-state"): pose blocks
// [p_w_b, q_w_b (x,y,z,w)], right-perturbed 6-dof tangent; speed-bias [v_w_b, b_a, b_g];
// inverse depth in the host camera; extrinsic T_b_c0 as a pose block. They are benchmark
// stand-ins, not the estimator's factors (those live in core/ and cite the paper's equations).

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "solver/manifold.hpp"
#include "solver/residual.hpp"

namespace ums::bench {

inline Eigen::Matrix3d skew(const Eigen::Vector3d& v) {
  Eigen::Matrix3d m;
  m << 0.0, -v.z(), v.y(), v.z(), 0.0, -v.x(), -v.y(), v.x(), 0.0;
  return m;
}

// Observation of a landmark hosted in camera 0 of frame i, seen in camera t of frame j (j != i):
//   p_c0i = bearing_i / rho,  p_b = T_b_c0 p_c0i,  p_w = T_w_bi p_b,  p_bj = T_w_bj^-1 p_w,
//   p_c0j = T_b_c0^-1 p_bj,   p_ct = T_c0_ct^-1 p_c0j,   r = sqrt_info (pi(p_ct) - uv_j)
// Blocks: pose_i (7), pose_j (7), T_b_c0 (7), rho (1). Returns false behind the camera.
class ReprojectionResidual final : public solver::ResidualFunction {
 public:
  ReprojectionResidual(const Eigen::Vector3d& bearing_i, const Eigen::Vector2d& uv_j,
                       const Eigen::Quaterniond& q_c0_ct, const Eigen::Vector3d& t_c0_ct,
                       double sqrt_info)
      : bearing_i_(bearing_i), uv_j_(uv_j), R_c0_ct_(q_c0_ct.toRotationMatrix()), t_c0_ct_(t_c0_ct),
        sqrt_info_(sqrt_info) {}

  int num_residuals() const override { return 2; }
  // The point is p_w (HostPointLift): with jac[0].point, d r / d p_w goes there.
  bool supports_point_jacobian() const override { return true; }

  bool evaluate(const double* const* x, double* residuals,
                const solver::JacobianView* jac) const override {
    const Eigen::Map<const Eigen::Vector3d> p_i(x[0]);
    const Eigen::Matrix3d R_i = Eigen::Map<const Eigen::Quaterniond>(x[0] + 3).toRotationMatrix();
    const Eigen::Map<const Eigen::Vector3d> p_j(x[1]);
    const Eigen::Matrix3d R_j = Eigen::Map<const Eigen::Quaterniond>(x[1] + 3).toRotationMatrix();
    const Eigen::Map<const Eigen::Vector3d> t_bc(x[2]);
    const Eigen::Matrix3d R_bc = Eigen::Map<const Eigen::Quaterniond>(x[2] + 3).toRotationMatrix();
    const double rho = x[3][0];

    const Eigen::Vector3d p_ci = bearing_i_ / rho;
    const Eigen::Vector3d p_bi = R_bc * p_ci + t_bc;
    const Eigen::Vector3d p_w = R_i * p_bi + p_i;
    const Eigen::Vector3d p_bj = R_j.transpose() * (p_w - p_j);
    const Eigen::Vector3d p_c0j = R_bc.transpose() * (p_bj - t_bc);
    const Eigen::Vector3d p_ct = R_c0_ct_.transpose() * (p_c0j - t_c0_ct_);
    if (!(p_ct.z() > 1e-6)) return false;
    const double inv_z = 1.0 / p_ct.z();
    Eigen::Map<Eigen::Vector2d> r(residuals);
    r = sqrt_info_ * (Eigen::Vector2d(p_ct.x() * inv_z, p_ct.y() * inv_z) - uv_j_);

    const bool any = jac[0].wanted() || jac[1].wanted() || jac[2].wanted() || jac[3].wanted();
    if (!any) return true;
    // Chain of 2x3 row blocks d r / d (point in each frame); a * skew(v) is the row-wise a x v.
    Eigen::Matrix<double, 2, 3> d_r_d_pct;
    d_r_d_pct << inv_z, 0.0, -p_ct.x() * inv_z * inv_z, 0.0, inv_z, -p_ct.y() * inv_z * inv_z;
    d_r_d_pct *= sqrt_info_;
    const Eigen::Matrix<double, 2, 3> d_r_d_pc0j = d_r_d_pct * R_c0_ct_.transpose();
    const Eigen::Matrix<double, 2, 3> d_r_d_pbj = d_r_d_pc0j * R_bc.transpose();
    const Eigen::Matrix<double, 2, 3> d_r_d_pw = d_r_d_pbj * R_j.transpose();
    const Eigen::Matrix<double, 2, 3> d_r_d_pbi = d_r_d_pw * R_i;
    const Eigen::Matrix<double, 2, 3> d_r_d_pci = d_r_d_pbi * R_bc;
    auto times_skew = [](const Eigen::Matrix<double, 2, 3>& a, const Eigen::Vector3d& v) {
      Eigen::Matrix<double, 2, 3> out;
      out.row(0) = a.row(0).cross(v.transpose());
      out.row(1) = a.row(1).cross(v.transpose());
      return out;
    };
    if (jac[0].wanted() && jac[0].point) {
      solver::jacobian_map<2, 3>(jac[0]) = d_r_d_pw;
    } else if (jac[0].wanted()) {
      auto J = solver::jacobian_map<2, 6>(jac[0]);
      J.leftCols<3>() = d_r_d_pw;
      J.rightCols<3>() = -times_skew(d_r_d_pbi, p_bi);
    }
    if (jac[1].wanted()) {
      auto J = solver::jacobian_map<2, 6>(jac[1]);
      J.leftCols<3>() = -d_r_d_pw;
      J.rightCols<3>() = times_skew(d_r_d_pbj, p_bj);
    }
    if (jac[2].wanted()) {
      // t_bc moves p_bi by +dt and p_c0j by -R_bc^T dt; R_bc rotates both ends.
      auto J = solver::jacobian_map<2, 6>(jac[2]);
      J.leftCols<3>() = d_r_d_pbi - d_r_d_pbj;
      J.rightCols<3>() = times_skew(d_r_d_pc0j, p_c0j) - times_skew(d_r_d_pci, p_ci);
    }
    if (jac[3].wanted()) {
      auto J = solver::jacobian_map<2, 1>(jac[3]);
      J = d_r_d_pci * (-bearing_i_ / (rho * rho));
    }
    return true;
  }

 private:
  Eigen::Vector3d bearing_i_;
  Eigen::Vector2d uv_j_;
  Eigen::Matrix3d R_c0_ct_;
  Eigen::Vector3d t_c0_ct_;
  double sqrt_info_;
};

// The point of ReprojectionResidual's landmark, p_w = T_w_bi (T_b_c0 (bearing_i / rho)), and
// d p_w / d (pose_i tangent, rho) (solver::PointLift). Blocks: pose_i (7), rho (1), T_b_c0 (7).
class HostPointLift final : public solver::PointLift {
 public:
  explicit HostPointLift(const Eigen::Vector3d& bearing_i) : bearing_i_(bearing_i) {}

  bool evaluate(const double* const* x, double* G) const override {
    const Eigen::Matrix3d R_i = Eigen::Map<const Eigen::Quaterniond>(x[0] + 3).toRotationMatrix();
    const double rho = x[1][0];
    const Eigen::Map<const Eigen::Vector3d> t_bc(x[2]);
    const Eigen::Matrix3d R_bc = Eigen::Map<const Eigen::Quaterniond>(x[2] + 3).toRotationMatrix();
    const Eigen::Vector3d p_bi = R_bc * (bearing_i_ / rho) + t_bc;
    Eigen::Map<Eigen::Matrix<double, 3, 7, Eigen::RowMajor>> J(G);
    J.leftCols<3>().setIdentity();
    J.block<3, 3>(0, 3) = -R_i * skew(p_bi);
    J.col(6) = R_i * (R_bc * (-bearing_i_ / (rho * rho)));
    return true;
  }

 private:
  Eigen::Vector3d bearing_i_;
};

// Stereo observation in the host frame: p_c1 = T_c0_c1^-1 (bearing / rho), r = sqrt_info
// (pi(p_c1) - uv_1). Block: rho (1). Pure landmark information (fixes the depth).
class StereoHostResidual final : public solver::ResidualFunction {
 public:
  StereoHostResidual(const Eigen::Vector3d& bearing_i, const Eigen::Vector2d& uv_1,
                     const Eigen::Quaterniond& q_c0_c1, const Eigen::Vector3d& t_c0_c1,
                     double sqrt_info)
      : bearing_i_(bearing_i), uv_1_(uv_1), R_c0_c1_(q_c0_c1.toRotationMatrix()), t_c0_c1_(t_c0_c1),
        sqrt_info_(sqrt_info) {}

  int num_residuals() const override { return 2; }

  bool evaluate(const double* const* x, double* residuals,
                const solver::JacobianView* jac) const override {
    const double rho = x[0][0];
    const Eigen::Vector3d p_c1 = R_c0_c1_.transpose() * (bearing_i_ / rho - t_c0_c1_);
    if (!(p_c1.z() > 1e-6)) return false;
    const double inv_z = 1.0 / p_c1.z();
    Eigen::Map<Eigen::Vector2d> r(residuals);
    r = sqrt_info_ * (Eigen::Vector2d(p_c1.x() * inv_z, p_c1.y() * inv_z) - uv_1_);
    if (jac[0].wanted()) {
      Eigen::Matrix<double, 2, 3> d_r_d_p;
      d_r_d_p << inv_z, 0.0, -p_c1.x() * inv_z * inv_z, 0.0, inv_z, -p_c1.y() * inv_z * inv_z;
      solver::jacobian_map<2, 1>(jac[0]) =
          sqrt_info_ * d_r_d_p * R_c0_c1_.transpose() * (-bearing_i_ / (rho * rho));
    }
    return true;
  }

 private:
  Eigen::Vector3d bearing_i_;
  Eigen::Vector2d uv_1_;
  Eigen::Matrix3d R_c0_c1_;
  Eigen::Vector3d t_c0_c1_;
  double sqrt_info_;
};

// Preintegrated-IMU-like residual between consecutive frames (shape of paper eq. 1), with
// first-order bias correction around (ba0, bg0) and g_w = (0, 0, -g):
//   r_p  = R_i^T (p_j - p_i - v_i dt - 0.5 g_w dt^2) - (alpha + J_a_ba dba + J_a_bg dbg)
//   r_th = Log( (gamma Exp(J_g_bg dbg))^-1 R_i^T R_j )
//   r_v  = R_i^T (v_j - v_i - g_w dt) - (beta + J_b_ba dba + J_b_bg dbg)
//   r_ba = ba_j - ba_i,   r_bg = bg_j - bg_i,        whitened by an upper-triangular sqrt_info.
// Blocks: pose_i (7), speedbias_i (9), pose_j (7), speedbias_j (9).
struct ImuDelta {
  double dt_s = 0.1;
  Eigen::Vector3d alpha = Eigen::Vector3d::Zero();
  Eigen::Quaterniond gamma = Eigen::Quaterniond::Identity();
  Eigen::Vector3d beta = Eigen::Vector3d::Zero();
  Eigen::Matrix3d J_a_ba = Eigen::Matrix3d::Zero(), J_a_bg = Eigen::Matrix3d::Zero();
  Eigen::Matrix3d J_g_bg = Eigen::Matrix3d::Zero();
  Eigen::Matrix3d J_b_ba = Eigen::Matrix3d::Zero(), J_b_bg = Eigen::Matrix3d::Zero();
  Eigen::Vector3d ba0 = Eigen::Vector3d::Zero(), bg0 = Eigen::Vector3d::Zero();
  Eigen::Matrix<double, 15, 15> sqrt_info = Eigen::Matrix<double, 15, 15>::Identity();
  double gravity_m_s2 = 9.81;
};

class ImuLikeResidual final : public solver::ResidualFunction {
 public:
  explicit ImuLikeResidual(const ImuDelta& d) : d_(d) {}

  int num_residuals() const override { return 15; }

  bool evaluate(const double* const* x, double* residuals,
                const solver::JacobianView* jac) const override {
    const Eigen::Map<const Eigen::Vector3d> p_i(x[0]);
    const Eigen::Map<const Eigen::Quaterniond> q_i(x[0] + 3);
    const Eigen::Map<const Eigen::Vector3d> v_i(x[1]);
    const Eigen::Map<const Eigen::Vector3d> ba_i(x[1] + 3);
    const Eigen::Map<const Eigen::Vector3d> bg_i(x[1] + 6);
    const Eigen::Map<const Eigen::Vector3d> p_j(x[2]);
    const Eigen::Map<const Eigen::Quaterniond> q_j(x[2] + 3);
    const Eigen::Map<const Eigen::Vector3d> v_j(x[3]);
    const Eigen::Map<const Eigen::Vector3d> ba_j(x[3] + 3);
    const Eigen::Map<const Eigen::Vector3d> bg_j(x[3] + 6);
    const double dt = d_.dt_s;
    const Eigen::Vector3d g_w(0.0, 0.0, -d_.gravity_m_s2);
    const Eigen::Matrix3d R_i = q_i.toRotationMatrix();
    const Eigen::Matrix3d R_it = R_i.transpose();
    const Eigen::Matrix3d R_j = q_j.toRotationMatrix();
    const Eigen::Vector3d dba = ba_i - d_.ba0;
    const Eigen::Vector3d dbg = bg_i - d_.bg0;
    const Eigen::Vector3d phi = d_.J_g_bg * dbg;
    const Eigen::Quaterniond gamma_c = d_.gamma * solver::so3_exp(phi);
    const Eigen::Quaterniond E = gamma_c.conjugate() * q_i.conjugate() * q_j;

    const Eigen::Vector3d dp_w = p_j - p_i - v_i * dt - 0.5 * g_w * dt * dt;
    const Eigen::Vector3d dv_w = v_j - v_i - g_w * dt;
    Eigen::Matrix<double, 15, 1> r;
    r.segment<3>(0) = R_it * dp_w - (d_.alpha + d_.J_a_ba * dba + d_.J_a_bg * dbg);
    r.segment<3>(3) = solver::so3_log(E);
    r.segment<3>(6) = R_it * dv_w - (d_.beta + d_.J_b_ba * dba + d_.J_b_bg * dbg);
    r.segment<3>(9) = ba_j - ba_i;
    r.segment<3>(12) = bg_j - bg_i;
    Eigen::Map<Eigen::Matrix<double, 15, 1>> r_out(residuals);
    r_out.noalias() = d_.sqrt_info.triangularView<Eigen::Upper>() * r;

    const Eigen::Matrix3d Jr_inv = solver::so3_right_jacobian_inverse(r.segment<3>(3));
    if (jac[0].wanted()) {
      Eigen::Matrix<double, 15, 6> J = Eigen::Matrix<double, 15, 6>::Zero();
      J.block<3, 3>(0, 0) = -R_it;
      J.block<3, 3>(0, 3) = skew(R_it * dp_w);
      J.block<3, 3>(3, 3) = -Jr_inv * R_j.transpose() * R_i;
      J.block<3, 3>(6, 3) = skew(R_it * dv_w);
      solver::jacobian_map<15, 6>(jac[0]) = d_.sqrt_info.triangularView<Eigen::Upper>() * J;
    }
    if (jac[1].wanted()) {
      Eigen::Matrix<double, 15, 9> J = Eigen::Matrix<double, 15, 9>::Zero();
      J.block<3, 3>(0, 0) = -R_it * dt;
      J.block<3, 3>(0, 3) = -d_.J_a_ba;
      J.block<3, 3>(0, 6) = -d_.J_a_bg;
      J.block<3, 3>(3, 6) = -Jr_inv * E.toRotationMatrix().transpose() *
                            solver::so3_right_jacobian(phi) * d_.J_g_bg;
      J.block<3, 3>(6, 0) = -R_it;
      J.block<3, 3>(6, 3) = -d_.J_b_ba;
      J.block<3, 3>(6, 6) = -d_.J_b_bg;
      J.block<3, 3>(9, 3) = -Eigen::Matrix3d::Identity();
      J.block<3, 3>(12, 6) = -Eigen::Matrix3d::Identity();
      solver::jacobian_map<15, 9>(jac[1]) = d_.sqrt_info.triangularView<Eigen::Upper>() * J;
    }
    if (jac[2].wanted()) {
      Eigen::Matrix<double, 15, 6> J = Eigen::Matrix<double, 15, 6>::Zero();
      J.block<3, 3>(0, 0) = R_it;
      J.block<3, 3>(3, 3) = Jr_inv;
      solver::jacobian_map<15, 6>(jac[2]) = d_.sqrt_info.triangularView<Eigen::Upper>() * J;
    }
    if (jac[3].wanted()) {
      Eigen::Matrix<double, 15, 9> J = Eigen::Matrix<double, 15, 9>::Zero();
      J.block<3, 3>(6, 0) = R_it;
      J.block<3, 3>(9, 3) = Eigen::Matrix3d::Identity();
      J.block<3, 3>(12, 6) = Eigen::Matrix3d::Identity();
      solver::jacobian_map<15, 9>(jac[3]) = d_.sqrt_info.triangularView<Eigen::Upper>() * J;
    }
    return true;
  }

 private:
  ImuDelta d_;
};

}  // namespace ums::bench
