#include "core/estimator/bearing_residual.hpp"

#include <cmath>

#include <Eigen/Geometry>

#include "core/math/so3.hpp"

namespace ums {

// One division: the A72 divides (and takes roots) far slower than it multiplies, and this runs
// for every edge of every problem build (docs/performance.md, "Cycles on a Cortex-A72 model").
Eigen::Vector3d BearingResidual::unit(const Eigen::Vector3d& v) {
  const double n = v.norm();
  return n > 0.0 ? Eigen::Vector3d(v * (1.0 / n)) : v;
}

void BearingResidual::set(Kind kind, bool same_camera, const Eigen::Vector3d& b_host,
                          const Eigen::Vector3d& b_target, double weight) {
  cache_ = nullptr;
  has_td_ = false;
  kind_ = kind;
  same_camera_ = kind == Kind::kSameFrame ? false : same_camera;
  b_host_ = unit(b_host);
  b_target_ = unit(b_target);
  weight_ = weight;
  // Any orthonormal pair normal to b_target: start from the axis least aligned with it.
  Eigen::Vector3d a = Eigen::Vector3d::UnitX();
  if (std::abs(b_target_.x()) > 0.6) a = Eigen::Vector3d::UnitY();
  const Eigen::Vector3d t1 = unit(a - b_target_ * b_target_.dot(a));
  tangent_t_.row(0) = t1.transpose();
  tangent_t_.row(1) = b_target_.cross(t1).transpose();
  count_blocks();
}

void BearingResidual::bind(RelativePoseCache* cache, int host_slot, int host_cam, int target_slot, int target_cam) {
  cache_ = cache;
  host_slot_ = static_cast<std::int8_t>(host_slot);
  host_cam_ = static_cast<std::int8_t>(host_cam);
  target_slot_ = static_cast<std::int8_t>(target_slot);
  target_cam_ = static_cast<std::int8_t>(target_cam);
}

void BearingResidual::set_time_offset(const Eigen::Vector3d& v_host, const Eigen::Vector3d& v_target,
                                      double td_applied_host_s, double td_applied_target_s) {
  has_td_ = true;
  v_host_ = v_host;
  v_target_ = v_target;
  td_applied_host_s_ = td_applied_host_s;
  td_applied_target_s_ = td_applied_target_s;
  count_blocks();
}

void BearingResidual::count_blocks() {
  const int td = static_cast<int>(has_td_);
  num_blocks_ = static_cast<std::int8_t>((kind_ == Kind::kSameFrame ? 3 : (same_camera_ ? 4 : 5)) + td);
}

// Inline (as project() below): small steps of every evaluation, whose call overhead showed in the
// profile.
__attribute__((always_inline)) inline void BearingResidual::shifted_bearings(const double* const* parameters, Eigen::Vector3d* b_host,
                                       Eigen::Vector3d* b_target) const {
  *b_host = b_host_;
  *b_target = b_target_;
  if (!has_td_) return;
  const double td_s = parameters[num_blocks() - 1][0];
  *b_host -= (td_s - td_applied_host_s_) * v_host_;
  *b_target -= (td_s - td_applied_target_s_) * v_target_;
}

void BearingResidual::write_td_jacobian(const Eigen::Matrix<double, 2, 3>& D, const Eigen::Matrix3d& R_ct_ch,
                                        double inv_rho, const solver::JacobianView* jacobians) const {
  const int k = num_blocks() - 1;
  if (!has_td_ || !jacobians[k].wanted()) return;
  // r = w B^T (u(P_ct) - b_t(td)): P_ct moves with the host bearing, b_t with its own velocity.
  solver::jacobian_map<2, 1>(jacobians[k]) =
      D * (R_ct_ch * (-v_host_ * inv_rho)) + weight_ * (tangent_t_ * v_target_);
}

namespace {

struct Pose {
  Eigen::Vector3d p;
  Eigen::Matrix3d R;
};

// The solver keeps quaternions unit (its plus is q * Exp(d), renormalized), so no normalization
// here: this runs for every residual at every linearization.
Pose read_pose(const double* x) {
  const Eigen::Map<const Eigen::Quaterniond> q(x + 3);
  return {Eigen::Vector3d(x[0], x[1], x[2]), q.toRotationMatrix()};
}

}  // namespace

// The residual from the point in the target camera and, when D is given, d r / d P_ct (2x3):
// the projection onto the unit sphere, then onto the tangent plane.
__attribute__((always_inline)) inline bool BearingResidual::project(const Eigen::Vector3d& P_ct, const Eigen::Vector3d& b_target, double* residuals,
                              Eigen::Matrix<double, 2, 3>* D) const {
  const double n = P_ct.norm();
  if (!(n > 1e-9) || P_ct.dot(b_target_) <= 0.0) return false;
  const double inv_n = 1.0 / n;
  const Eigen::Vector3d u = P_ct * inv_n;
  // Written out: Eigen kept the 2-vector assignment out of line (a call per evaluation).
  const Eigen::Vector3d e = u - b_target;
  // Eigen folds the scalar into the product's left factor: the same here, for the same doubles.
  residuals[0] = (weight_ * tangent_t_.row(0).transpose()).dot(e);
  residuals[1] = (weight_ * tangent_t_.row(1).transpose()).dot(e);
  if (!std::isfinite(residuals[0]) || !std::isfinite(residuals[1])) return false;
  // B^T (I - u u^T) = B^T - (B^T u) u^T.
  if (D != nullptr) *D = (weight_ * inv_n) * (tangent_t_ - (tangent_t_ * u) * u.transpose());
  return true;
}

namespace {

using solver::Pair;

inline Pair splat(double v) { return Pair{v, v}; }

// A 2 x 3 matrix as its columns, each a packet (row 0, row 1). Every entry below is computed as
// Eigen's scalar expression it replaces computes it, so the doubles are the same; the two rows
// share each instruction. Eigen (scalar, EIGEN_DONT_VECTORIZE) sums three products as
// p_0 + (p_1 + p_2): its unrolled reduction halves the range.
struct Cols23 {
  Pair c[3];
};

// A R: column j is A_0 R(0, j) + (A_1 R(1, j) + A_2 R(2, j)).
inline Cols23 times(const Cols23& A, const Eigen::Matrix3d& R) {
  Cols23 out;
  for (int j = 0; j < 3; ++j) out.c[j] = A.c[0] * splat(R(0, j)) + (A.c[1] * splat(R(1, j)) + A.c[2] * splat(R(2, j)));
  return out;
}

// A R^T: column j is A_0 R(j, 0) + (A_1 R(j, 1) + A_2 R(j, 2)).
inline Cols23 times_transpose(const Cols23& A, const Eigen::Matrix3d& R) {
  Cols23 out;
  for (int j = 0; j < 3; ++j) out.c[j] = A.c[0] * splat(R(j, 0)) + (A.c[1] * splat(R(j, 1)) + A.c[2] * splat(R(j, 2)));
  return out;
}

// A v: A_0 v_0 + (A_1 v_1 + A_2 v_2).
inline Pair times(const Cols23& A, const Eigen::Vector3d& v) {
  return A.c[0] * splat(v.x()) + (A.c[1] * splat(v.y()) + A.c[2] * splat(v.z()));
}

// A hat(v), row by row a x v: (a_1 v_2 - a_2 v_1, a_2 v_0 - a_0 v_2, a_0 v_1 - a_1 v_0), Eigen's cross.
inline Cols23 times_hat(const Cols23& A, const Eigen::Vector3d& v) {
  return Cols23{{A.c[1] * splat(v.z()) - A.c[2] * splat(v.y()), A.c[2] * splat(v.x()) - A.c[0] * splat(v.z()),
                 A.c[0] * splat(v.y()) - A.c[1] * splat(v.x())}};
}

inline Cols23 negated(const Cols23& A) { return Cols23{{-A.c[0], -A.c[1], -A.c[2]}}; }

// A into columns c0 .. c0 + 2 of the 2-row row-major block at J (row stride s).
inline void store_rows(const Cols23& A, const solver::JacobianView& J, int c0) {
  double* r0 = J.data + c0;
  double* r1 = r0 + J.row_stride;
  for (int k = 0; k < 3; ++k) {
    r0[k] = A.c[k][0];
    r1[k] = A.c[k][1];
  }
}

}  // namespace

__attribute__((always_inline)) inline bool BearingResidual::project_packets(const Eigen::Vector3d& P_ct,
                                                                            const Eigen::Vector3d& b_target,
                                                                            double* residuals, Pair* D) const {
  const double n = P_ct.norm();
  if (!(n > 1e-9) || P_ct.dot(b_target_) <= 0.0) return false;
  const double inv_n = 1.0 / n;
  const Eigen::Vector3d u = P_ct * inv_n;
  const Eigen::Vector3d e = u - b_target;
  // B^T's columns and w B^T's (Eigen scales the tangent first, then takes the dot product).
  Pair bt[3], wbt[3];
  const Pair w = splat(weight_);
  for (int k = 0; k < 3; ++k) {
    bt[k] = solver::load_pair(tangent_t_.data() + 2 * k);
    wbt[k] = w * bt[k];
  }
  const Pair r = wbt[0] * splat(e.x()) + (wbt[1] * splat(e.y()) + wbt[2] * splat(e.z()));
  residuals[0] = r[0];
  residuals[1] = r[1];
  if (!std::isfinite(residuals[0]) || !std::isfinite(residuals[1])) return false;
  if (D != nullptr) {
    // (w / n) (B^T - (B^T u) u^T), column by column.
    const Pair btu = bt[0] * splat(u.x()) + (bt[1] * splat(u.y()) + bt[2] * splat(u.z()));
    const Pair s = splat(weight_ * inv_n);
    for (int k = 0; k < 3; ++k) D[k] = s * (bt[k] - btu * splat(u[k]));
  }
  return true;
}

bool BearingResidual::evaluate_cached(const double* const* parameters, double* residuals,
                                      const solver::JacobianView* jacobians) const {
  const int k_rho = rho_block();
  const double rho = parameters[k_rho][0];
  if (!(rho > 1e-6) || !std::isfinite(rho)) return false;
  const RelativePoseCache::Pair& c = cache_->pair(host_slot_, host_cam_, target_slot_, target_cam_);
  Eigen::Vector3d b_h, b_t;
  shifted_bearings(parameters, &b_h, &b_t);
  const double inv_rho = 1.0 / rho;
  const Eigen::Vector3d P_ch = b_h * inv_rho;
  const Eigen::Vector3d P_ct = c.R_ct_ch * P_ch + c.p_ct_ch;
  // The solver's cost passes hand a view with nothing wanted: then no d r / d P_ct either.
  const bool any = jacobians != nullptr && (jacobians[0].wanted() || jacobians[1].wanted() ||
                                            jacobians[k_rho].wanted() || (has_td_ && jacobians[k_rho + 1].wanted()));
  Cols23 D;
  if (!project_packets(P_ct, b_t, residuals, any ? D.c : nullptr)) return false;
  if (!any) return true;
  // The same Jacobians as evaluate()'s, from the shared products (R_ct_bt = R_b_ct^T), in packets.
  const bool want_h = jacobians[0].wanted(), want_t = jacobians[1].wanted();
  if (want_h || want_t) {
    const Cols23 DR = times(D, c.R_ct_w);
    if (want_h && jacobians[0].point) {
      store_rows(DR, jacobians[0], 0);
    } else if (want_h) {
      const Eigen::Vector3d P_bh = c.R_b_ch * P_ch + c.p_b_ch;
      store_rows(DR, jacobians[0], 0);
      store_rows(negated(times_hat(times(D, c.R_ct_bh), P_bh)), jacobians[0], 3);
    }
    if (want_t) {
      const Eigen::Vector3d P_bt = c.R_b_ct * P_ct + c.p_b_ct;
      store_rows(negated(DR), jacobians[1], 0);
      store_rows(times_hat(times_transpose(D, c.R_b_ct), P_bt), jacobians[1], 3);
    }
  }
  if (jacobians[k_rho].wanted() || has_td_) {
    Eigen::Matrix<double, 2, 3> De;
    for (int k = 0; k < 3; ++k) De.col(k) = Eigen::Vector2d(D.c[k][0], D.c[k][1]);
    if (jacobians[k_rho].wanted()) {
      const Pair j = times(D, Eigen::Vector3d(c.R_ct_ch * (-P_ch * inv_rho)));
      jacobians[k_rho].data[0] = j[0];
      jacobians[k_rho].data[jacobians[k_rho].row_stride] = j[1];
    }
    if (has_td_) write_td_jacobian(De, c.R_ct_ch, inv_rho, jacobians);
  }
  return true;
}

// The stereo pair of the host frame from the cache's camera pair: only rho (and td) can be wanted
// here, the extrinsics' Jacobians take evaluate()'s own path.
bool BearingResidual::evaluate_same_frame_cached(const double* const* parameters, double* residuals,
                                                 const solver::JacobianView* jacobians) const {
  const int k_rho = rho_block();
  const double rho = parameters[k_rho][0];
  if (!(rho > 1e-6) || !std::isfinite(rho)) return false;
  const RelativePoseCache::CameraPair& c = cache_->camera_pair(host_cam_, target_cam_);
  Eigen::Vector3d b_h, b_t;
  shifted_bearings(parameters, &b_h, &b_t);
  const double inv_rho = 1.0 / rho;
  const Eigen::Vector3d P_ch = b_h * inv_rho;
  const Eigen::Vector3d P_ct = c.R_ct_ch * P_ch + c.p_ct_ch;
  const bool any = jacobians != nullptr && (jacobians[k_rho].wanted() || (has_td_ && jacobians[k_rho + 1].wanted()));
  Eigen::Matrix<double, 2, 3> D;
  if (!project(P_ct, b_t, residuals, any ? &D : nullptr)) return false;
  if (!any) return true;
  if (jacobians[k_rho].wanted())
    solver::jacobian_map<2, 1>(jacobians[k_rho]) = D * (c.R_ct_ch * (-P_ch * inv_rho));
  if (has_td_) write_td_jacobian(D, c.R_ct_ch, inv_rho, jacobians);
  return true;
}

bool BearingResidual::error_rad(const double* const* parameters, double* error) const {
  double r[2];
  if (!evaluate(parameters, r, nullptr) || !(weight_ > 0.0)) return false;
  *error = std::sqrt(r[0] * r[0] + r[1] * r[1]) / weight_;
  return true;
}

namespace {

// The points and rotations of one evaluation, which the Jacobians reuse.
struct Chain {
  bool two_frames = false;
  int k_ext_h = 0, k_ext_t = 0, k_rho = 0;  // parameter index of each block
  double rho = 0.0;
  double inv_rho = 0.0;  // 1 / rho: one division per evaluation
  Pose ext_h{}, ext_t{}, pose_h{}, pose_t{};
  Eigen::Vector3d P_ch, P_bh, P_bt, P_ct;   // the point in host camera, host body, target body, target camera
  Eigen::Matrix<double, 2, 3> D;            // d residual / d P_ct
};

// d r / d (host pose, target pose, extrinsics, inverse depth) by the chain rule through P_ct.
void write_jacobians(const Chain& c, const solver::JacobianView* jacobians) {
  const Eigen::Matrix3d R_ct_bt = c.ext_t.R.transpose();
  const bool want_h = c.two_frames && jacobians[0].wanted();
  const bool want_t = c.two_frames && jacobians[1].wanted();
  const bool want_eh = jacobians[c.k_ext_h].wanted();
  const bool want_et = jacobians[c.k_ext_t].wanted();
  const bool want_rho = jacobians[c.k_rho].wanted();
  // M maps a vector of host body coordinates into target camera coordinates.
  Eigen::Matrix3d R_ct_w = R_ct_bt;
  Eigen::Matrix3d M = R_ct_bt;
  if (c.two_frames) {
    R_ct_w = R_ct_bt * c.pose_t.R.transpose();
    if (want_h || want_eh || want_rho) M = R_ct_w * c.pose_h.R;
  }
  if (want_h && jacobians[0].point) {
    solver::jacobian_map<2, 3>(jacobians[0]) = c.D * R_ct_w;
  } else if (want_h) {
    Eigen::Matrix<double, 3, 6> d;
    d.leftCols<3>() = R_ct_w;
    d.rightCols<3>() = -M * so3::hat(c.P_bh);
    solver::jacobian_map<2, 6>(jacobians[0]) = c.D * d;
  }
  if (want_t) {
    Eigen::Matrix<double, 3, 6> d;
    d.leftCols<3>() = -R_ct_w;
    d.rightCols<3>() = R_ct_bt * so3::hat(c.P_bt);
    solver::jacobian_map<2, 6>(jacobians[1]) = c.D * d;
  }
  // Extrinsics (constant unless estimated): host side moves P_bh, target side the target camera.
  if (want_eh || want_et) {
    Eigen::Matrix<double, 3, 6> d_h;
    d_h.leftCols<3>() = M;
    d_h.rightCols<3>() = -M * c.ext_h.R * so3::hat(c.P_ch);
    Eigen::Matrix<double, 3, 6> d_t;
    d_t.leftCols<3>() = -R_ct_bt;
    d_t.rightCols<3>() = so3::hat(c.P_ct);
    if (c.k_ext_h == c.k_ext_t) {
      solver::jacobian_map<2, 6>(jacobians[c.k_ext_h]) = c.D * (d_h + d_t);
    } else {
      if (want_eh) solver::jacobian_map<2, 6>(jacobians[c.k_ext_h]) = c.D * d_h;
      if (want_et) solver::jacobian_map<2, 6>(jacobians[c.k_ext_t]) = c.D * d_t;
    }
  }
  if (want_rho) {
    const Eigen::Vector3d d_rho = M * (c.ext_h.R * (-c.P_ch * c.inv_rho));
    solver::jacobian_map<2, 1>(jacobians[c.k_rho]) = c.D * d_rho;
  }
}

}  // namespace

bool BearingResidual::evaluate(const double* const* parameters, double* residuals,
                               const solver::JacobianView* jacobians) const {
  const bool two_frames = kind_ == Kind::kTwoFrames;
  const int k_ext_h = two_frames ? 2 : 0;
  const int k_ext_t = two_frames ? (same_camera_ ? 2 : 3) : 1;
  // Nearly every evaluation takes a cached path: decided before the chain's storage is set up.
  if (cache_ != nullptr && parameters[k_ext_h] == cache_->extrinsic(host_cam_) &&
      parameters[k_ext_t] == cache_->extrinsic(target_cam_) &&
      (jacobians == nullptr || (!jacobians[k_ext_h].wanted() && !jacobians[k_ext_t].wanted()))) {
    if (!two_frames) return evaluate_same_frame_cached(parameters, residuals, jacobians);
    if (parameters[0] == cache_->frame(host_slot_) && parameters[1] == cache_->frame(target_slot_))
      return evaluate_cached(parameters, residuals, jacobians);
  }
  return evaluate_uncached(parameters, residuals, jacobians);
}

// The chain from the blocks' own values: extrinsics' Jacobians, or parameters the cache does not hold.
bool BearingResidual::evaluate_uncached(const double* const* parameters, double* residuals,
                                        const solver::JacobianView* jacobians) const {
  const bool two_frames = kind_ == Kind::kTwoFrames;
  Chain c;
  c.two_frames = two_frames;
  c.k_ext_h = two_frames ? 2 : 0;
  c.k_ext_t = two_frames ? (same_camera_ ? 2 : 3) : 1;
  c.k_rho = rho_block();

  c.rho = parameters[c.k_rho][0];
  if (!(c.rho > 1e-6) || !std::isfinite(c.rho)) return false;
  c.ext_h = read_pose(parameters[c.k_ext_h]);
  c.ext_t = read_pose(parameters[c.k_ext_t]);

  Eigen::Vector3d b_h, b_t;
  shifted_bearings(parameters, &b_h, &b_t);
  c.inv_rho = 1.0 / c.rho;
  c.P_ch = b_h * c.inv_rho;
  c.P_bh = c.ext_h.R * c.P_ch + c.ext_h.p;
  if (c.two_frames) {
    c.pose_h = read_pose(parameters[0]);
    c.pose_t = read_pose(parameters[1]);
    const Eigen::Vector3d P_w = c.pose_h.R * c.P_bh + c.pose_h.p;
    c.P_bt = c.pose_t.R.transpose() * (P_w - c.pose_t.p);
  } else {
    c.P_bt = c.P_bh;
  }
  c.P_ct = c.ext_t.R.transpose() * (c.P_bt - c.ext_t.p);
  if (!project(c.P_ct, b_t, residuals, jacobians == nullptr ? nullptr : &c.D)) return false;
  if (jacobians == nullptr) return true;
  write_jacobians(c, jacobians);
  if (has_td_) {
    Eigen::Matrix3d R_bt_bh = Eigen::Matrix3d::Identity();
    if (c.two_frames) R_bt_bh = c.pose_t.R.transpose() * c.pose_h.R;
    write_td_jacobian(c.D, c.ext_t.R.transpose() * R_bt_bh * c.ext_h.R, c.inv_rho, jacobians);
  }
  return true;
}

}  // namespace ums
