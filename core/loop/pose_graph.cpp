#include "core/loop/pose_graph.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

#include <Eigen/Cholesky>

#include "core/common/assert.hpp"
#include "core/math/quaternion.hpp"

namespace ums::loop {

namespace {

constexpr std::size_t kVecLen = 4 * capacity::kMaxKeyframes;
enum VecSlot : std::size_t { kB = 0, kDx, kR, kZ, kD, kQ, kNumVecs };
// Floor of the LM damping's diag(H) entries: a node whose block is still (near) empty gets a
// positive-definite preconditioner block instead of a failed factorization.
constexpr double kMinDamping = 1e-6;
constexpr double kMinLambda = 1e-12;

using Vec4Map = Eigen::Map<Eigen::Vector4d>;
using ConstVec4Map = Eigen::Map<const Eigen::Vector4d>;

// Node k's 4-block of a vector over all nodes.
Vec4Map block(double* v, int k) { return Vec4Map(v + 4 * k); }
ConstVec4Map block(const double* v, int k) { return ConstVec4Map(v + 4 * k); }

solver::RobustLoss edge_loss(EdgeKind kind, const PoseGraphOptions& options) {
  if (kind != EdgeKind::kLoop) return solver::RobustLoss::trivial();
  return solver::RobustLoss{options.loop_loss, options.loop_loss_scale};
}

// Whitened Jacobians of an edge as 4x4 blocks, fixed nodes' columns zeroed.
void expand(const Eigen::Matrix3d& Rt, const Eigen::Vector3d& d, double w_p, double w_yaw,
            double mask_i, double mask_j, Eigen::Matrix4d* J_i, Eigen::Matrix4d* J_j) {
  J_i->setZero();
  J_i->topLeftCorner<3, 3>() = -w_p * mask_i * Rt;
  J_i->block<3, 1>(0, 3) = w_p * mask_i * d;
  (*J_i)(3, 3) = -w_yaw * mask_i;
  J_j->setZero();
  J_j->topLeftCorner<3, 3>() = w_p * mask_j * Rt;
  (*J_j)(3, 3) = w_yaw * mask_j;
}

}  // namespace

void PoseGraphOptions::validate() const {
  auto fail = [](const char* field, double v) {
    throw std::invalid_argument(std::string("PoseGraphOptions.") + field + " out of range: " + std::to_string(v));
  };
  if (max_iterations < 1) fail("max_iterations", max_iterations);
  if (max_cg_iterations < 1) fail("max_cg_iterations", max_cg_iterations);
  if (!(cg_relative_tolerance >= 0.0)) fail("cg_relative_tolerance", cg_relative_tolerance);
  if (!(loop_loss_scale > 0.0)) fail("loop_loss_scale", loop_loss_scale);
  if (!(initial_lambda > 0.0)) fail("initial_lambda", initial_lambda);
  if (!(function_tolerance >= 0.0)) fail("function_tolerance", function_tolerance);
  if (!(step_tolerance >= 0.0)) fail("step_tolerance", step_tolerance);
}

Eigen::Vector4d four_dof_residual(const Pose4Dof& x_i, const Eigen::Matrix3d& R_rp_i,
                                  const Pose4Dof& x_j, const RelativePose4Dof& z_i_j,
                                  Eigen::Matrix4d* d_r_d_x_i, Eigen::Matrix4d* d_r_d_x_j) {
  const double c = std::cos(x_i.yaw_rad);
  const double s = std::sin(x_i.yaw_rad);
  Eigen::Matrix3d Rz_t;  // Rz(yaw_i)^T
  Rz_t << c, s, 0.0, -s, c, 0.0, 0.0, 0.0, 1.0;
  const Eigen::Vector3d p_w_ij = x_j.p_w_b_m - x_i.p_w_b_m;
  const Eigen::Matrix3d R_i_w = R_rp_i.transpose() * Rz_t;
  Eigen::Vector4d r;
  r.head<3>() = R_i_w * p_w_ij - z_i_j.t_i_j_m;
  r(3) = quat::wrap_angle_rad(x_j.yaw_rad - x_i.yaw_rad - z_i_j.yaw_i_j_rad);
  if (d_r_d_x_i) {
    Eigen::Matrix3d dRz_t;  // d Rz(yaw)^T / d yaw
    dRz_t << -s, c, 0.0, -c, -s, 0.0, 0.0, 0.0, 0.0;
    d_r_d_x_i->setZero();
    d_r_d_x_i->topLeftCorner<3, 3>() = -R_i_w;
    d_r_d_x_i->block<3, 1>(0, 3) = R_rp_i.transpose() * (dRz_t * p_w_ij);
    (*d_r_d_x_i)(3, 3) = -1.0;
  }
  if (d_r_d_x_j) {
    d_r_d_x_j->setZero();
    d_r_d_x_j->topLeftCorner<3, 3>() = R_i_w;
    (*d_r_d_x_j)(3, 3) = 1.0;
  }
  return r;
}

PoseGraph4Dof::PoseGraph4Dof()
    : x_(new Pose4Dof[kMaxNodes]),
      x_saved_(new Pose4Dof[kMaxNodes]),
      R_rp_(new Eigen::Matrix3d[kMaxNodes]),
      fixed_(new std::uint8_t[kMaxNodes]()),
      edges_(new Edge[kMaxEdges]),
      jac_(new EdgeJacobian[kMaxEdges]),
      H_diag_(new Eigen::Matrix4d[kMaxNodes]),
      H_upper_(new Eigen::Matrix4d[kMaxNodes]),
      S_inv_(new Eigen::Matrix4d[kMaxNodes]),
      G_(new Eigen::Matrix4d[kMaxNodes]),
      vec_(new double[kNumVecs * kVecLen]()) {}

PoseGraph4Dof::~PoseGraph4Dof() = default;

void PoseGraph4Dof::clear() {
  n_nodes_ = 0;
  n_edges_ = 0;
}

std::size_t PoseGraph4Dof::footprint_bytes() const {
  const std::size_t per_node = 2 * sizeof(Pose4Dof) + sizeof(Eigen::Matrix3d) + sizeof(std::uint8_t) +
                               4 * sizeof(Eigen::Matrix4d);
  const std::size_t per_edge = sizeof(Edge) + sizeof(EdgeJacobian);
  return sizeof(*this) + kMaxNodes * per_node + kMaxEdges * per_edge + kNumVecs * kVecLen * sizeof(double);
}

Status PoseGraph4Dof::add_node(const Eigen::Isometry3d& T_w_b, int* index) {
  if (!T_w_b.matrix().allFinite()) return Status::kInvalidInput;
  if (n_nodes_ >= kMaxNodes) return Status::kFull;
  const int k = n_nodes_++;
  x_[k].p_w_b_m = T_w_b.translation();
  x_[k].yaw_rad = quat::yaw(T_w_b.linear());
  R_rp_[k] = quat::remove_yaw(T_w_b.linear());
  fixed_[k] = k == 0 ? 1 : 0;  // the gauge, until set_fixed() says otherwise
  if (index) *index = k;
  return Status::kOk;
}

Status PoseGraph4Dof::add_edge(int i, int j, const Eigen::Isometry3d& T_i_j, double sigma_p_m,
                               double sigma_yaw_rad, EdgeKind kind) {
  if (!valid_index(i) || !valid_index(j) || i == j) return Status::kInvalidInput;
  if (!T_i_j.matrix().allFinite()) return Status::kInvalidInput;
  // Written so that NaN sigmas fail too.
  if (!(sigma_p_m > 0.0 && sigma_yaw_rad > 0.0 && std::isfinite(sigma_p_m) && std::isfinite(sigma_yaw_rad)))
    return Status::kInvalidInput;
  if (n_edges_ >= kMaxEdges) return Status::kFull;
  Edge& e = edges_[n_edges_++];
  e.i = i;
  e.j = j;
  e.z.t_i_j_m = T_i_j.translation();
  // yaw(Rz(yaw_i) R_rp_i R_i_j) - yaw_i: node j's yaw relative to i, free of i's roll and pitch.
  e.z.yaw_i_j_rad = quat::yaw(R_rp_[i] * T_i_j.linear());
  e.inv_sigma_p = 1.0 / sigma_p_m;
  e.inv_sigma_yaw = 1.0 / sigma_yaw_rad;
  e.kind = kind;
  return Status::kOk;
}

Status PoseGraph4Dof::add_odometry_edge(int i, int j, double sigma_p_m, double sigma_yaw_rad) {
  if (!valid_index(i) || !valid_index(j)) return Status::kInvalidInput;
  return add_edge(i, j, pose(i).inverse(Eigen::Isometry) * pose(j), sigma_p_m, sigma_yaw_rad,
                  EdgeKind::kOdometry);
}

Status PoseGraph4Dof::set_fixed(int i, bool fixed) {
  if (!valid_index(i)) return Status::kInvalidInput;
  fixed_[i] = fixed ? 1 : 0;
  return Status::kOk;
}

Eigen::Isometry3d PoseGraph4Dof::pose(int i) const {
  UMS_ASSERT(valid_index(i));
  Eigen::Isometry3d T_w_b = Eigen::Isometry3d::Identity();
  T_w_b.linear() = Eigen::AngleAxisd(x_[i].yaw_rad, Eigen::Vector3d::UnitZ()).toRotationMatrix() * R_rp_[i];
  T_w_b.translation() = x_[i].p_w_b_m;
  return T_w_b;
}

const Pose4Dof& PoseGraph4Dof::state(int i) const {
  UMS_ASSERT(valid_index(i));
  return x_[i];
}

double PoseGraph4Dof::edge_cost(const Edge& e, const Eigen::Vector4d& r_white,
                                const PoseGraphOptions& options) const {
  double rho[3];
  edge_loss(e.kind, options).evaluate(r_white.squaredNorm(), rho);
  return 0.5 * rho[0];
}

double PoseGraph4Dof::evaluate_cost(const PoseGraphOptions& options) const {
  double cost = 0.0;
  for (int k = 0; k < n_edges_; ++k) {
    const Edge& e = edges_[k];
    Eigen::Vector4d r = four_dof_residual(x_[e.i], R_rp_[e.i], x_[e.j], e.z, nullptr, nullptr);
    r.head<3>() *= e.inv_sigma_p;
    r(3) *= e.inv_sigma_yaw;
    cost += edge_cost(e, r, options);
  }
  return cost;
}

double PoseGraph4Dof::linearize(const PoseGraphOptions& options) {
  double* b = vec_.get() + kB * kVecLen;
  std::fill(b, b + 4 * n_nodes_, 0.0);
  for (int k = 0; k < n_nodes_; ++k) {
    H_diag_[k].setZero();
    H_upper_[k].setZero();
  }
  double cost = 0.0;
  for (int k = 0; k < n_edges_; ++k) {
    const Edge& e = edges_[k];
    Eigen::Matrix4d J_i;
    Eigen::Vector4d r = four_dof_residual(x_[e.i], R_rp_[e.i], x_[e.j], e.z, &J_i, nullptr);
    r.head<3>() *= e.inv_sigma_p;
    r(3) *= e.inv_sigma_yaw;
    double rho[3];
    edge_loss(e.kind, options).evaluate(r.squaredNorm(), rho);
    cost += 0.5 * rho[0];
    // Huber and Cauchy have rho'' <= 0, where Triggs' correction (solver/loss.hpp) reduces to
    // scaling r and J by sqrt(rho'): the compact form below stays valid.
    const double scale = std::sqrt(rho[1]);
    EdgeJacobian& J = jac_[k];
    J.Rt = -J_i.topLeftCorner<3, 3>();
    J.d = J_i.block<3, 1>(0, 3);
    J.w_p = scale * e.inv_sigma_p;
    J.w_yaw = scale * e.inv_sigma_yaw;
    J.mask_i = fixed_[e.i] ? 0.0 : 1.0;
    J.mask_j = fixed_[e.j] ? 0.0 : 1.0;
    accumulate_blocks(e, J, scale * r);
  }
  return cost;
}

void PoseGraph4Dof::accumulate_blocks(const Edge& e, const EdgeJacobian& J, const Eigen::Vector4d& r_white) {
  Eigen::Matrix4d J_i, J_j;
  expand(J.Rt, J.d, J.w_p, J.w_yaw, J.mask_i, J.mask_j, &J_i, &J_j);
  double* b = vec_.get() + kB * kVecLen;
  block(b, e.i) -= J_i.transpose() * r_white;
  block(b, e.j) -= J_j.transpose() * r_white;
  H_diag_[e.i] += J_i.transpose() * J_i;
  H_diag_[e.j] += J_j.transpose() * J_j;
  // Edges between consecutive nodes form the chain the block-tridiagonal preconditioner keeps.
  if (e.j == e.i + 1) H_upper_[e.i] += J_i.transpose() * J_j;
  if (e.i == e.j + 1) H_upper_[e.j] += J_j.transpose() * J_i;
}

bool PoseGraph4Dof::factor_preconditioner(double lambda, PoseGraphPreconditioner kind) {
  const bool chain = kind == PoseGraphPreconditioner::kChain;
  for (int k = 0; k < n_nodes_; ++k) {
    G_[k].setZero();
    if (fixed_[k]) {  // its rows and columns of H are zero; an identity keeps z_k = r_k = 0
      S_inv_[k].setIdentity();
      continue;
    }
    Eigen::Matrix4d S = H_diag_[k];
    for (int c = 0; c < 4; ++c) S(c, c) += lambda * std::max(H_diag_[k](c, c), kMinDamping);
    // Block Thomas: S_k = M_kk - M_k-1,k^T S_k-1^-1 M_k-1,k, with G_k-1 = S_k-1^-1 M_k-1,k.
    if (chain && k > 0) S.noalias() -= H_upper_[k - 1].transpose() * G_[k - 1];
    const Eigen::LLT<Eigen::Matrix4d> llt(S);
    if (llt.info() != Eigen::Success) return false;
    S_inv_[k] = llt.solve(Eigen::Matrix4d::Identity());
    if (chain && k + 1 < n_nodes_) G_[k].noalias() = S_inv_[k] * H_upper_[k];
  }
  return true;
}

void PoseGraph4Dof::apply_preconditioner(const double* r, double* z) const {
  // M = L D L^T with L_k+1,k = G_k^T, D = diag(S_k): forward, scale, backward (G = 0 for block
  // Jacobi, where this is z_k = S_k^-1 r_k).
  block(z, 0) = block(r, 0);
  for (int k = 1; k < n_nodes_; ++k) block(z, k) = block(r, k) - G_[k - 1].transpose() * block(z, k - 1);
  const int last = n_nodes_ - 1;
  block(z, last) = S_inv_[last] * block(z, last);
  for (int k = last - 1; k >= 0; --k) {
    const Eigen::Vector4d w = block(z, k);
    block(z, k) = S_inv_[k] * w - G_[k] * block(z, k + 1);
  }
}

void PoseGraph4Dof::apply_hessian(double lambda, const double* d, double* q) const {
  for (int k = 0; k < n_nodes_; ++k) {
    for (int c = 0; c < 4; ++c) {
      const double damping = fixed_[k] ? 0.0 : lambda * std::max(H_diag_[k](c, c), kMinDamping);
      q[4 * k + c] = damping * d[4 * k + c];
    }
  }
  for (int k = 0; k < n_edges_; ++k) {
    const EdgeJacobian& J = jac_[k];
    const double* d_i = d + 4 * edges_[k].i;
    const double* d_j = d + 4 * edges_[k].j;
    // y = J_i d_i + J_j d_j, then q_i += J_i^T y, q_j += J_j^T y (compact forms, see the header).
    const Eigen::Vector3d dp = J.mask_j * Eigen::Vector3d(d_j[0], d_j[1], d_j[2]) -
                               J.mask_i * Eigen::Vector3d(d_i[0], d_i[1], d_i[2]);
    const Eigen::Vector3d y_p = J.w_p * (J.Rt * dp + J.mask_i * d_i[3] * J.d);
    const double y_yaw = J.w_yaw * (J.mask_j * d_j[3] - J.mask_i * d_i[3]);
    const Eigen::Vector3d g_p = J.w_p * (J.Rt.transpose() * y_p);
    double* q_i = q + 4 * edges_[k].i;
    double* q_j = q + 4 * edges_[k].j;
    for (int c = 0; c < 3; ++c) {
      q_i[c] -= J.mask_i * g_p(c);
      q_j[c] += J.mask_j * g_p(c);
    }
    q_i[3] += J.mask_i * (J.w_p * J.d.dot(y_p) - J.w_yaw * y_yaw);
    q_j[3] += J.mask_j * J.w_yaw * y_yaw;
  }
}

int PoseGraph4Dof::solve_pcg(double lambda, const PoseGraphOptions& options) {
  const Eigen::Index n = 4 * n_nodes_;
  double* base = vec_.get();
  Eigen::Map<Eigen::VectorXd> b(base + kB * kVecLen, n), x(base + kDx * kVecLen, n),
      r(base + kR * kVecLen, n), z(base + kZ * kVecLen, n), d(base + kD * kVecLen, n),
      q(base + kQ * kVecLen, n);
  x.setZero();
  const double b_norm = b.norm();
  if (b_norm == 0.0) return 0;
  r = b;
  apply_preconditioner(r.data(), z.data());
  d = z;
  double rz = r.dot(z);
  const double tolerance = options.cg_relative_tolerance * b_norm;
  int it = 0;
  while (it < options.max_cg_iterations) {
    apply_hessian(lambda, d.data(), q.data());
    const double dq = d.dot(q);
    if (!(dq > 0.0)) break;  // round-off at convergence, or a direction of zero curvature
    const double alpha = rz / dq;
    x.noalias() += alpha * d;
    r.noalias() -= alpha * q;
    ++it;
    if (r.norm() <= tolerance) break;
    apply_preconditioner(r.data(), z.data());
    const double rz_next = r.dot(z);
    d = z + (rz_next / rz) * d;
    rz = rz_next;
  }
  return it;
}

double PoseGraph4Dof::apply_step() {
  const double* dx = vec_.get() + kDx * kVecLen;
  double max_step = 0.0;
  for (int k = 0; k < n_nodes_; ++k) {
    if (fixed_[k]) continue;
    const ConstVec4Map step = block(dx, k);
    x_[k].p_w_b_m += step.head<3>();
    x_[k].yaw_rad = quat::wrap_angle_rad(x_[k].yaw_rad + step(3));
    max_step = std::max(max_step, step.cwiseAbs().maxCoeff());
  }
  return max_step;
}

PoseGraphSummary PoseGraph4Dof::optimize(const PoseGraphOptions& options) {
  options.validate();
  PoseGraphSummary summary;
  if (n_edges_ == 0) {
    summary.status = Status::kNotEnoughData;
    return summary;
  }
  double cost = linearize(options);
  summary.initial_cost = cost;
  double lambda = options.initial_lambda;
  while (summary.iterations < options.max_iterations && !summary.converged) {
    ++summary.iterations;
    if (!factor_preconditioner(lambda, options.preconditioner)) {
      summary.status = Status::kSingular;
      break;
    }
    const int cg = solve_pcg(lambda, options);
    summary.cg_iterations += cg;
    summary.max_cg_iterations_used = std::max(summary.max_cg_iterations_used, cg);
    std::copy(x_.get(), x_.get() + n_nodes_, x_saved_.get());
    const double step = apply_step();
    const double trial_cost = evaluate_cost(options);
    if (!(trial_cost <= cost)) {  // worse (or NaN): back, and damp more
      std::copy(x_saved_.get(), x_saved_.get() + n_nodes_, x_.get());
      lambda *= 10.0;
      continue;
    }
    ++summary.accepted;
    lambda = std::max(lambda * 0.1, kMinLambda);
    summary.converged = step <= options.step_tolerance || cost - trial_cost <= options.function_tolerance * cost;
    cost = summary.converged ? trial_cost : linearize(options);
  }
  summary.final_cost = cost;
  if (summary.status == Status::kOk && !summary.converged) summary.status = Status::kNotConverged;
  return summary;
}

}  // namespace ums::loop
