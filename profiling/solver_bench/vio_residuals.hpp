#pragma once
// VIO-shaped residuals for the solver benchmark and the solver tests: the same code is evaluated by
// our solver and (through thin adapters) by Ceres, so the two solve the identical problem.
// They follow the product's conventions (../shared notes "conventions-state"): pose blocks
// [p_w_b, q_w_b (x,y,z,w)], right-perturbed 6-dof tangent; speed-bias [v_w_b, b_a, b_g];
// inverse depth in the host camera; extrinsic T_b_c0 as a pose block. They are benchmark
// stand-ins, not the estimator's factors (those live in core/ and cite the paper's equations).

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <algorithm>
#include <cstdint>
#include <cstring>
#include <vector>

#include "solver/manifold.hpp"
#include "solver/residual.hpp"

namespace ums::bench {

inline Eigen::Matrix3d skew(const Eigen::Vector3d& v) {
  Eigen::Matrix3d m;
  m << 0.0, -v.z(), v.y(), v.z(), 0.0, -v.x(), -v.y(), v.x(), 0.0;
  return m;
}

// The rotation and translation products that every reprojection of one (host frame i, target
// frame j, target camera t) combination shares, as the product's visual residual has them
// (core/estimator/relative_pose_cache.hpp): a window's 2,600 reprojections connect some 200
// combinations, so the products are formed once per combination and evaluation point instead of
// once per residual. An entry is keyed by the values it was formed at (pose_i, pose_j, T_b_c0):
// a lookup compares them and re-forms on any difference. Results are thus a function of the
// values passed in alone, whoever evaluates (ours, Ceres, a test with perturbed copies), and no
// solver has to announce a new evaluation point. Not thread-safe (both solvers run one thread).
class PairProductCache {
 public:
  struct Products {
    Eigen::Matrix3d R_ct_w;   // world -> target camera
    Eigen::Matrix3d R_ct_bi;  // host body -> target camera
    Eigen::Matrix3d R_ct_ci;  // host camera -> target camera
    Eigen::Vector3d p_ct_ci;  // host camera origin in the target camera
    Eigen::Matrix3d R_ct_bj;  // target body -> target camera (R_c0_ct^T R_bc^T)
    Eigen::Matrix3d R_bc;     // the extrinsic T_b_c0
    Eigen::Vector3d t_bc;
  };

  // frames: the window's; R_c0_ct[t], t_c0_ct[t]: camera t in camera 0 (t = 0 the identity).
  PairProductCache(int frames, const Eigen::Matrix3d R_c0_ct[2], const Eigen::Vector3d t_c0_ct[2])
      : frames_(frames), entries_(static_cast<std::size_t>(frames * frames * 2)) {
    for (int t = 0; t < 2; ++t) {
      R_c0_ct_[t] = R_c0_ct[t];
      t_c0_ct_[t] = t_c0_ct[t];
    }
  }

  const Eigen::Matrix3d& R_c0_ct(int t) const { return R_c0_ct_[t]; }
  const Eigen::Vector3d& t_c0_ct(int t) const { return t_c0_ct_[t]; }

  const Products& at(int i, int j, int t, const double* pose_i, const double* pose_j, const double* T_bc) {
    Entry& e = entries_[static_cast<std::size_t>((i * frames_ + j) * 2 + t)];
    if (!e.valid || !same(e.key, pose_i) || !same(e.key + 7, pose_j) || !same(e.key + 14, T_bc)) form(e, t, pose_i, pose_j, T_bc);
    return e.p;
  }

 private:
  struct Entry {
    bool valid = false;
    double key[21] = {};
    Products p;
  };
  // Bit patterns, not ==: one branch for the block instead of two per double (NaN's parity), and
  // equal bits give equal products.
  static bool same(const double* a, const double* b) {
    std::uint64_t diff = 0;
    for (int k = 0; k < 7; ++k) {
      std::uint64_t ua, ub;
      std::memcpy(&ua, a + k, sizeof ua);
      std::memcpy(&ub, b + k, sizeof ub);
      diff |= ua ^ ub;
    }
    return diff == 0;
  }
  void form(Entry& e, int t, const double* pose_i, const double* pose_j, const double* T_bc) {
    std::copy(pose_i, pose_i + 7, e.key);
    std::copy(pose_j, pose_j + 7, e.key + 7);
    std::copy(T_bc, T_bc + 7, e.key + 14);
    e.valid = true;
    Products& c = e.p;
    const Eigen::Matrix3d R_i = Eigen::Map<const Eigen::Quaterniond>(pose_i + 3).toRotationMatrix();
    const Eigen::Matrix3d R_j = Eigen::Map<const Eigen::Quaterniond>(pose_j + 3).toRotationMatrix();
    c.R_bc = Eigen::Map<const Eigen::Quaterniond>(T_bc + 3).toRotationMatrix();
    c.t_bc = Eigen::Vector3d(T_bc[0], T_bc[1], T_bc[2]);
    const Eigen::Vector3d p_i(pose_i[0], pose_i[1], pose_i[2]);
    const Eigen::Vector3d p_j(pose_j[0], pose_j[1], pose_j[2]);
    // p_ct = R_c0_ct^T (R_bc^T (R_j^T (R_i (R_bc p_ci + t_bc) + p_i - p_j) - t_bc) - t_c0_ct)
    c.R_ct_bj.noalias() = R_c0_ct_[t].transpose() * c.R_bc.transpose();
    c.R_ct_w.noalias() = c.R_ct_bj * R_j.transpose();
    c.R_ct_bi.noalias() = c.R_ct_w * R_i;
    c.R_ct_ci.noalias() = c.R_ct_bi * c.R_bc;
    c.p_ct_ci.noalias() = c.R_ct_bi * c.t_bc + c.R_ct_w * (p_i - p_j) - c.R_ct_bj * c.t_bc -
                          R_c0_ct_[t].transpose() * t_c0_ct_[t];
  }

  int frames_;
  Eigen::Matrix3d R_c0_ct_[2];
  Eigen::Vector3d t_c0_ct_[2];
  std::vector<Entry> entries_;
};

// Observation of a landmark hosted in camera 0 of frame i, seen in camera t of frame j (j != i):
//   p_c0i = bearing_i / rho,  p_b = T_b_c0 p_c0i,  p_w = T_w_bi p_b,  p_bj = T_w_bj^-1 p_w,
//   p_c0j = T_b_c0^-1 p_bj,   p_ct = T_c0_ct^-1 p_c0j,   r = sqrt_info (pi(p_ct) - uv_j)
// evaluated as p_ct = R_ct_ci p_c0i + p_ct_ci with the combination's products (PairProductCache).
// Blocks: pose_i (7), pose_j (7), T_b_c0 (7), rho (1). Returns false behind the camera.
class ReprojectionResidual final : public solver::ResidualFunction {
 public:
  ReprojectionResidual(const Eigen::Vector3d& bearing_i, const Eigen::Vector2d& uv_j, int frame_i, int frame_j,
                       int camera_t, double sqrt_info, PairProductCache* cache)
      : bearing_i_(bearing_i), uv_j_(uv_j), i_(frame_i), j_(frame_j), t_(camera_t), sqrt_info_(sqrt_info),
        cache_(cache) {}

  // The same observation with its products kept in `cache` (tests).
  ReprojectionResidual with_cache(PairProductCache* cache) const {
    ReprojectionResidual copy = *this;
    copy.cache_ = cache;
    return copy;
  }

  int num_residuals() const override { return 2; }
  // The point is p_w (HostPointLift): with jac[0].point, d r / d p_w goes there.
  bool supports_point_jacobian() const override { return true; }

  bool evaluate(const double* const* x, double* residuals,
                const solver::JacobianView* jac) const override {
    const PairProductCache::Products& c = cache_->at(i_, j_, t_, x[0], x[1], x[2]);
    const double rho = x[3][0];
    const Eigen::Vector3d p_ci = bearing_i_ / rho;
    const Eigen::Vector3d p_ct = c.R_ct_ci * p_ci + c.p_ct_ci;
    if (!(p_ct.z() > 1e-6)) return false;
    const double inv_z = 1.0 / p_ct.z();
    Eigen::Map<Eigen::Vector2d> r(residuals);
    r = sqrt_info_ * (Eigen::Vector2d(p_ct.x() * inv_z, p_ct.y() * inv_z) - uv_j_);

    const bool any = jac[0].wanted() || jac[1].wanted() || jac[2].wanted() || jac[3].wanted();
    if (!any) return true;
    // d r / d (the point in frame f) = P R_ct_f, with P = d r / d p_ct = k [1 0 -u; 0 1 -v]
    // (k = sqrt_info / z): its zeros make each product 18 operations instead of 30. a * skew(v)
    // is the row-wise a x v.
    const double k = sqrt_info_ * inv_z, u = p_ct.x() * inv_z, v = p_ct.y() * inv_z;
    auto P_times = [k, u, v](const Eigen::Matrix3d& R) {
      Eigen::Matrix<double, 2, 3> out;
      out.row(0) = k * (R.row(0) - u * R.row(2));
      out.row(1) = k * (R.row(1) - v * R.row(2));
      return out;
    };
    auto times_skew = [](const Eigen::Matrix<double, 2, 3>& a, const Eigen::Vector3d& w) {
      Eigen::Matrix<double, 2, 3> out;
      out.row(0) = a.row(0).cross(w.transpose());
      out.row(1) = a.row(1).cross(w.transpose());
      return out;
    };
    const Eigen::Matrix<double, 2, 3> d_r_d_pw = P_times(c.R_ct_w);
    if (jac[0].wanted() && jac[0].point) {
      solver::jacobian_map<2, 3>(jac[0]) = d_r_d_pw;
    } else if (jac[0].wanted()) {
      auto J = solver::jacobian_map<2, 6>(jac[0]);
      J.leftCols<3>() = d_r_d_pw;
      J.rightCols<3>() = -times_skew(P_times(c.R_ct_bi), c.R_bc * p_ci + c.t_bc);
    }
    if (!jac[1].wanted() && !jac[2].wanted() && !jac[3].wanted()) return true;
    const Eigen::Matrix<double, 2, 3> d_r_d_pci = P_times(c.R_ct_ci);
    if (jac[1].wanted() || jac[2].wanted()) {
      // Camera 0 is the frame's reference camera: skip the identity (the same doubles).
      const bool cam0 = t_ == 0;
      const Eigen::Vector3d p_c0j = cam0 ? p_ct : Eigen::Vector3d(cache_->R_c0_ct(t_) * p_ct + cache_->t_c0_ct(t_));
      const Eigen::Matrix<double, 2, 3> d_r_d_pbj = P_times(c.R_ct_bj);
      if (jac[1].wanted()) {
        auto J = solver::jacobian_map<2, 6>(jac[1]);
        J.leftCols<3>() = -d_r_d_pw;
        J.rightCols<3>() = times_skew(d_r_d_pbj, c.R_bc * p_c0j + c.t_bc);
      }
      if (jac[2].wanted()) {
        // t_bc moves p_bi by +dt and p_c0j by -R_bc^T dt; R_bc rotates both ends.
        const Eigen::Matrix<double, 2, 3> d_r_d_pc0j =
            cam0 ? P_times(Eigen::Matrix3d::Identity()) : P_times(cache_->R_c0_ct(t_).transpose());
        auto J = solver::jacobian_map<2, 6>(jac[2]);
        J.leftCols<3>() = P_times(c.R_ct_bi) - d_r_d_pbj;
        J.rightCols<3>() = times_skew(d_r_d_pc0j, p_c0j) - times_skew(d_r_d_pci, p_ci);
      }
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
  int i_, j_, t_;
  double sqrt_info_;
  PairProductCache* cache_;
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
