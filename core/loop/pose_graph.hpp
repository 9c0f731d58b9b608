#pragma once
// The 4-DoF pose graph of loop closure (VINS-Mono, Qin et al., T-RO 2018, sec. VIII): a
// visual-inertial odometry drifts in position and yaw only (roll and pitch are observable from
// gravity), so each keyframe node i carries p_w_i (3, m) and yaw_i (rad, about world z, z up),
// and keeps the roll and pitch it was added with:
//
//   R_w_i = Rz(yaw_i) * R_rp_i,   R_rp_i = Rz(-yaw(R_w_i)) * R_w_i at add_node()   (ZYX split)
//
// An edge (i, j) measures t_i_ij = R_w_i^T (p_w_j - p_w_i) and yaw_ij = yaw_j - yaw_i, with the
// residual (VINS-Mono's FourDOFError)
//
//   r_p   = (Rz(yaw_i) R_rp_i)^T (p_w_j - p_w_i) - t_i_ij      3 rows, m
//   r_yaw = wrap(yaw_j - yaw_i - yaw_ij)                        1 row, rad
//
// each divided by its sigma. Odometry edges are plain least squares; loop edges get a robust loss
// on the whitened residual: Cauchy by default (a loop 5 m wrong beside true ones moves the test's
// circle by < 3 cm), or Huber as VINS-Mono has it (24 cm there: its pull does not fade). Fixed
// nodes (the first by default) hold the 4 gauge dofs.
//
// Solver: Levenberg-Marquardt whose linear step is preconditioned conjugate gradients, matrix-free
// (each edge's whitened Jacobian is kept in compact form once per linearization and H*x is applied
// edge by edge). Two preconditioners: 4x4 block Jacobi, or the block-tridiagonal part of H (the
// odometry chain between consecutive node indices, factored exactly by block Thomas in O(n)),
// which leaves only the loop edges for CG to resolve. Every buffer is sized at construction for
// kMaxKeyframes nodes and kMaxKeyframes + kMaxLoopEdges edges; optimize() allocates nothing.
// Its time is bounded: each of at most max_iterations LM steps is one linearization and one cost
// evaluation (an edge pass each), one O(n) factorization, and at most max_cg_iterations PCG
// iterations (an edge pass plus an O(n) preconditioner solve each). With the defaults, 2000 nodes
// and 500 loops take ~170-185 ms of CPU in that worst case on the 2-core AMD EPYC development host
// (the test prints it); a drifted graph of that size converges in 6 steps and ~630 CG iterations.
// Block Jacobi needs ~14x the CG iterations there (a chain's condition number grows as n^2).

#include <cstddef>
#include <cstdint>
#include <memory>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "core/common/capacity.hpp"
#include "core/common/status.hpp"
#include "solver/loss.hpp"

namespace ums::loop {

// The optimized part of a node: position and yaw.
struct Pose4Dof {
  Eigen::Vector3d p_w_b_m = Eigen::Vector3d::Zero();
  double yaw_rad = 0.0;
};

// What an edge (i, j) measures.
struct RelativePose4Dof {
  Eigen::Vector3d t_i_j_m = Eigen::Vector3d::Zero();  // p_w_j - p_w_i in node i's frame (R_w_i)
  double yaw_i_j_rad = 0.0;                           // yaw_j - yaw_i
};

// The unwhitened residual [r_p (m), r_yaw (rad)] above, and its Jacobians with respect to
// x_i and x_j, columns ordered [dp (3), dyaw]. R_rp_i: node i's fixed roll/pitch rotation.
Eigen::Vector4d four_dof_residual(const Pose4Dof& x_i, const Eigen::Matrix3d& R_rp_i,
                                  const Pose4Dof& x_j, const RelativePose4Dof& z_i_j,
                                  Eigen::Matrix4d* d_r_d_x_i, Eigen::Matrix4d* d_r_d_x_j);

enum class EdgeKind : std::uint8_t { kOdometry = 0, kLoop };

enum class PoseGraphPreconditioner : std::uint8_t {
  kBlockJacobi = 0,  // H's 4x4 diagonal blocks
  kChain,            // H's block tridiagonal (edges |i - j| = 1 and every diagonal block)
};

struct PoseGraphOptions {
  int max_iterations = 8;             // LM steps, accepted or rejected (the time bound)
  int max_cg_iterations = 200;        // PCG iterations per LM step (the time bound; 2000 nodes
                                      // with 500 loops took <= 175 in every layout measured)
  double cg_relative_tolerance = 1e-6;  // PCG stops when |H dx - b| <= this * |b|
  PoseGraphPreconditioner preconditioner = PoseGraphPreconditioner::kChain;
  solver::LossType loop_loss = solver::LossType::kCauchy;  // on loop edges only
  double loop_loss_scale = 1.0;       // whitened residual norm where the loop loss leaves quadratic
  double initial_lambda = 1e-6;       // LM damping, relative to diag(H); x10 on a rejected step
  double function_tolerance = 1e-12;  // converged: relative cost decrease below this
  double step_tolerance = 1e-9;       // converged: every step component below this (m and rad)

  void validate() const;  // throws std::invalid_argument naming the field and value
};

struct PoseGraphSummary {
  Status status = Status::kOk;  // kNotConverged: stopped on max_iterations; kSingular: a
                                // preconditioner block failed; kNotEnoughData: no edge
  int iterations = 0;           // LM steps tried
  int accepted = 0;             // of which accepted
  int cg_iterations = 0;        // PCG iterations over all steps
  int max_cg_iterations_used = 0;  // the most in one step (== the cap: PCG stopped on it)
  double initial_cost = 0.0;    // 0.5 sum rho(|whitened r|^2)
  double final_cost = 0.0;
  bool converged = false;
};

class PoseGraph4Dof {
 public:
  static constexpr int kMaxNodes = static_cast<int>(capacity::kMaxKeyframes);
  static constexpr int kMaxEdges = static_cast<int>(capacity::kMaxKeyframes + capacity::kMaxLoopEdges);

  PoseGraph4Dof();  // allocates everything
  ~PoseGraph4Dof();
  PoseGraph4Dof(const PoseGraph4Dof&) = delete;
  PoseGraph4Dof& operator=(const PoseGraph4Dof&) = delete;

  void clear();
  // A node at T_w_b (its roll and pitch stay; yaw and position are optimized). The first node is
  // fixed. kFull at kMaxNodes, kInvalidInput for a non-finite pose; index may be null.
  Status add_node(const Eigen::Isometry3d& T_w_b, int* index);
  // An edge measuring T_i_j = T_w_i^-1 T_w_j: t_i_ij = T_i_j.translation(), yaw_ij =
  // yaw(R_rp_i R_i_j) (equal to yaw_j - yaw_i whatever node i's roll and pitch). kFull at
  // kMaxEdges; kInvalidInput for a bad index, i == j, a sigma <= 0 or non-finite input.
  Status add_edge(int i, int j, const Eigen::Isometry3d& T_i_j, double sigma_p_m,
                  double sigma_yaw_rad, EdgeKind kind);
  // An odometry edge measuring the two nodes' current relative pose.
  Status add_odometry_edge(int i, int j, double sigma_p_m, double sigma_yaw_rad);
  // kInvalidInput for a bad index.
  Status set_fixed(int i, bool fixed);

  // Allocates nothing; the nodes hold the result. Throws only on invalid options.
  PoseGraphSummary optimize(const PoseGraphOptions& options);

  // R_w_b = Rz(yaw) R_rp, p_w_b: the node's current (optimized) pose. i must be a node.
  Eigen::Isometry3d pose(int i) const;
  const Pose4Dof& state(int i) const;
  int num_nodes() const { return n_nodes_; }
  int num_edges() const { return n_edges_; }
  std::size_t footprint_bytes() const;

 private:
  struct Edge {
    int i, j;
    RelativePose4Dof z;
    double inv_sigma_p, inv_sigma_yaw;  // 1/m, 1/rad
    EdgeKind kind;
  };
  // Whitened, loss-corrected Jacobians of one edge in compact form (masked columns of fixed
  // nodes are zero): J_i = [-w_p Rt, w_p d; 0, -w_yaw], J_j = [w_p Rt, 0; 0, w_yaw].
  struct EdgeJacobian {
    Eigen::Matrix3d Rt;  // R_w_i^T
    Eigen::Vector3d d;   // d r_p / d yaw_i
    double w_p, w_yaw;   // whitening x sqrt(rho')
    double mask_i, mask_j;
  };

  bool valid_index(int i) const { return i >= 0 && i < n_nodes_; }
  double linearize(const PoseGraphOptions& options);
  double evaluate_cost(const PoseGraphOptions& options) const;
  double edge_cost(const Edge& e, const Eigen::Vector4d& r_white, const PoseGraphOptions& options) const;
  void accumulate_blocks(const Edge& e, const EdgeJacobian& J, const Eigen::Vector4d& r_white);
  bool factor_preconditioner(double lambda, PoseGraphPreconditioner kind);
  void apply_preconditioner(const double* r, double* z) const;
  void apply_hessian(double lambda, const double* d, double* q) const;
  int solve_pcg(double lambda, const PoseGraphOptions& options);
  double apply_step();  // x += dx; returns max |dx|

  int n_nodes_ = 0;
  int n_edges_ = 0;
  std::unique_ptr<Pose4Dof[]> x_;          // per node
  std::unique_ptr<Pose4Dof[]> x_saved_;    // per node: the state before a trial step
  std::unique_ptr<Eigen::Matrix3d[]> R_rp_;  // per node
  std::unique_ptr<std::uint8_t[]> fixed_;  // per node
  std::unique_ptr<Edge[]> edges_;
  std::unique_ptr<EdgeJacobian[]> jac_;    // per edge
  std::unique_ptr<Eigen::Matrix4d[]> H_diag_;   // per node: H_kk (undamped)
  std::unique_ptr<Eigen::Matrix4d[]> H_upper_;  // per node: H_k,k+1
  std::unique_ptr<Eigen::Matrix4d[]> S_inv_;    // per node: inverse Schur block of the preconditioner
  std::unique_ptr<Eigen::Matrix4d[]> G_;        // per node: S_k^-1 H_k,k+1
  std::unique_ptr<double[]> vec_;  // 6 vectors of 4 kMaxNodes: b, dx, r, z, d, q
};

}  // namespace ums::loop
