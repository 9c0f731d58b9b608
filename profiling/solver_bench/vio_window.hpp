#pragma once
// A synthetic VIO-shaped sliding window (fixed seed) for the solver benchmark and tests: keyframes
// of pose + speed-bias, one extrinsic T_b_c0, inverse-depth landmarks hosted in their first
// frame with 3..11 observations (mono in later frames, stereo in the host frame and in some later
// frames), Huber on visual residuals, IMU-like 15-dim residuals between consecutive frames, and a
// dense prior over the poses, the first speed-bias and the extrinsic (which also fixes the gauge).
// Set-up code: std::vector and unique_ptr are fine here.

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <array>
#include <cmath>
#include <cstdint>
#include <memory>
#include <vector>

#include "profiling/solver_bench/vio_residuals.hpp"
#include "solver/loss.hpp"
#include "solver/marginal_prior.hpp"
#include "solver/problem.hpp"

namespace ums::bench {

// Deterministic across compilers and architectures (no std:: distributions).
class Rng {
 public:
  explicit Rng(std::uint64_t seed) : s_(seed) {}
  std::uint64_t next() {
    std::uint64_t z = (s_ += 0x9E3779B97F4A7C15ull);
    z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
    z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
    return z ^ (z >> 31);
  }
  double uniform(double lo, double hi) {
    return lo + (hi - lo) * static_cast<double>(next() >> 11) * (1.0 / 9007199254740992.0);
  }
  int uniform_int(int lo, int hi) {  // inclusive
    return lo + static_cast<int>(next() % static_cast<std::uint64_t>(hi - lo + 1));
  }
  double normal() {
    const double u1 = uniform(1e-12, 1.0);
    const double u2 = uniform(0.0, 1.0);
    return std::sqrt(-2.0 * std::log(u1)) * std::cos(6.283185307179586 * u2);
  }
  Eigen::Vector3d normal3() { return {normal(), normal(), normal()}; }

 private:
  std::uint64_t s_;
};

struct WindowConfig {
  int frames = 11;
  int landmarks = 300;
  int min_obs = 3;
  int max_obs = 11;
  double stereo_fraction = 0.5;    // of observations that also get a right-camera residual
  double outlier_fraction = 0.03;  // of observations with a gross error (Huber active)
  double pixel_sigma = 0.5;        // px at focal 460
  double huber_delta = 1.0;        // whitened units (VINS)
  bool with_prior = true;
  bool noise_free = false;         // exact measurements and a zero-gradient prior: optimum = truth
  bool point_lifts = true;         // add_to_problem declares each landmark's HostPointLift
  std::uint64_t seed = 42;
};

enum class BlockKind : std::uint8_t { kPose, kSpeedBias, kExtrinsic, kInverseDepth };
struct BlockRef {
  BlockKind kind = BlockKind::kPose;
  int index = 0;
};
struct ResidualDesc {
  const solver::ResidualFunction* fn = nullptr;
  solver::RobustLoss loss;
  int num_blocks = 0;
  BlockRef blocks[4];
};

struct VioWindow {
  WindowConfig config;
  std::vector<std::array<double, 7>> poses, poses_true;
  std::vector<std::array<double, 9>> speed_bias, speed_bias_true;
  std::array<double, 7> extrinsic{}, extrinsic_true{};
  std::vector<double> inv_depth, inv_depth_true;
  std::vector<int> host;  // host frame of each landmark
  std::vector<std::unique_ptr<HostPointLift>> lifts;  // per landmark
  std::unique_ptr<PairProductCache> products;          // shared by the reprojection residuals
  // Initial values (solves restart from these).
  std::vector<std::array<double, 7>> poses0;
  std::vector<std::array<double, 9>> speed_bias0;
  std::array<double, 7> extrinsic0{};
  std::vector<double> inv_depth0;

  std::vector<std::unique_ptr<solver::ResidualFunction>> functions;
  std::vector<ResidualDesc> residuals;
  std::unique_ptr<solver::MarginalPrior> prior;
  std::vector<BlockRef> prior_blocks;

  double* data(const BlockRef& b) {
    switch (b.kind) {
      case BlockKind::kPose: return poses[b.index].data();
      case BlockKind::kSpeedBias: return speed_bias[b.index].data();
      case BlockKind::kExtrinsic: return extrinsic.data();
      case BlockKind::kInverseDepth: return &inv_depth[b.index];
    }
    return nullptr;
  }
  void reset() {
    poses = poses0;
    speed_bias = speed_bias0;
    extrinsic = extrinsic0;
    inv_depth = inv_depth0;
  }
  int num_visual() const {
    int n = 0;
    for (const auto& r : residuals) n += r.fn->num_residuals() == 2 ? 1 : 0;
    return n;
  }
};

inline void put_pose(std::array<double, 7>& out, const Eigen::Vector3d& p, const Eigen::Quaterniond& q) {
  out = {p.x(), p.y(), p.z(), q.x(), q.y(), q.z(), q.w()};
}

inline std::unique_ptr<VioWindow> make_vio_window(const WindowConfig& cfg) {
  auto w = std::make_unique<VioWindow>();
  w->config = cfg;
  Rng rng(cfg.seed);
  const int F = cfg.frames;
  const double dt = 0.1;
  const double g = 9.81;
  const double focal = 460.0;
  const double sqrt_info = focal / 1.5;  // VINS-Fusion's visual weight
  const double sigma = cfg.noise_free ? 0.0 : cfg.pixel_sigma / focal;
  const double outliers = cfg.noise_free ? 0.0 : cfg.outlier_fraction;
  const double imu_noise = cfg.noise_free ? 0.0 : 1.0;

  // Truth: a smooth forward-moving, gently turning body; camera looks forward (z_c = x_b).
  w->poses_true.resize(F);
  w->speed_bias_true.resize(F);
  std::vector<Eigen::Vector3d> P(F), V(F);
  std::vector<Eigen::Quaterniond> Q(F);
  const Eigen::Vector3d ba(0.05, -0.03, 0.02), bg(0.002, -0.001, 0.003);
  for (int i = 0; i < F; ++i) {
    const double t = i * dt;
    P[i] = Eigen::Vector3d(1.0 * t, 0.3 * std::sin(2.0 * t), 0.1 * std::sin(3.0 * t));
    V[i] = Eigen::Vector3d(1.0, 0.6 * std::cos(2.0 * t), 0.3 * std::cos(3.0 * t));
    Q[i] = Eigen::AngleAxisd(0.3 * std::sin(1.5 * t), Eigen::Vector3d::UnitZ()) *
           Eigen::AngleAxisd(0.05 * std::sin(2.5 * t), Eigen::Vector3d::UnitY()) *
           Eigen::AngleAxisd(0.04 * std::cos(2.0 * t), Eigen::Vector3d::UnitX());
    put_pose(w->poses_true[i], P[i], Q[i]);
    w->speed_bias_true[i] = {V[i].x(), V[i].y(), V[i].z(), ba.x(), ba.y(), ba.z(),
                             bg.x(),   bg.y(),   bg.z()};
  }
  Eigen::Matrix3d R_bc;
  R_bc << 0, 0, 1, -1, 0, 0, 0, -1, 0;  // camera z forward = body x, camera x = -body y
  const Eigen::Quaterniond q_bc(R_bc);
  const Eigen::Vector3d t_bc(0.05, 0.02, -0.01);
  put_pose(w->extrinsic_true, t_bc, q_bc);
  const Eigen::Quaterniond q_c0c1 = Eigen::Quaterniond::Identity();
  const Eigen::Vector3d t_c0c1(0.095, 0.0, 0.0);  // D455 baseline
  {
    const Eigen::Matrix3d R_c0_ct[2] = {Eigen::Matrix3d::Identity(), q_c0c1.toRotationMatrix()};
    const Eigen::Vector3d t_c0_ct[2] = {Eigen::Vector3d::Zero(), t_c0c1};
    w->products = std::make_unique<PairProductCache>(F, R_c0_ct, t_c0_ct);
  }

  // Landmarks and observations.
  w->inv_depth_true.resize(cfg.landmarks);
  std::vector<int>& host = w->host;
  host.resize(cfg.landmarks);
  std::vector<int> nobs(cfg.landmarks);
  std::vector<Eigen::Vector3d> bearing(cfg.landmarks), p_w(cfg.landmarks);
  for (int l = 0; l < cfg.landmarks; ++l) {
    nobs[l] = rng.uniform_int(cfg.min_obs, std::min(cfg.max_obs, F));
    host[l] = rng.uniform_int(0, F - nobs[l]);
    const Eigen::Vector2d uv(rng.uniform(-0.5, 0.5), rng.uniform(-0.4, 0.4));
    const double depth = rng.uniform(2.0, 12.0);
    bearing[l] = Eigen::Vector3d(uv.x(), uv.y(), 1.0);
    w->inv_depth_true[l] = 1.0 / depth;
    const Eigen::Vector3d p_c = bearing[l] * depth;
    p_w[l] = Q[host[l]] * (q_bc * p_c + t_bc) + P[host[l]];
  }
  auto project = [&](int frame, const Eigen::Vector3d& pw, bool right, Eigen::Vector2d* uv) {
    const Eigen::Vector3d p_b = Q[frame].conjugate() * (pw - P[frame]);
    Eigen::Vector3d p_c = q_bc.conjugate() * (p_b - t_bc);
    if (right) p_c = q_c0c1.conjugate() * (p_c - t_c0c1);
    if (p_c.z() < 0.1) return false;
    *uv = p_c.head<2>() / p_c.z();
    return true;
  };
  auto noisy = [&](Eigen::Vector2d uv) {
    uv += sigma * Eigen::Vector2d(rng.normal(), rng.normal());
    if (rng.uniform(0.0, 1.0) < outliers)
      uv += (20.0 / focal) * Eigen::Vector2d(rng.normal(), rng.normal());
    return uv;
  };
  const solver::RobustLoss huber = solver::RobustLoss::huber(cfg.huber_delta);
  for (int l = 0; l < cfg.landmarks; ++l) {
    const int h = host[l];
    Eigen::Vector2d uv;
    // The host observation defines the bearing (as VINS does), with its own noise.
    // (pixel noise only: a gross error in the host observation would corrupt the whole track)
    const Eigen::Vector2d uv_h = bearing[l].head<2>() + sigma * Eigen::Vector2d(rng.normal(), rng.normal());
    const Eigen::Vector3d b_meas(uv_h.x(), uv_h.y(), 1.0);
    w->lifts.push_back(std::make_unique<HostPointLift>(b_meas));
    if (rng.uniform(0.0, 1.0) < cfg.stereo_fraction && project(h, p_w[l], true, &uv)) {
      w->functions.push_back(std::make_unique<StereoHostResidual>(b_meas, noisy(uv), q_c0c1, t_c0c1, sqrt_info));
      ResidualDesc d;
      d.fn = w->functions.back().get();
      d.loss = huber;
      d.num_blocks = 1;
      d.blocks[0] = {BlockKind::kInverseDepth, l};
      w->residuals.push_back(d);
    }
    for (int j = h + 1; j < h + nobs[l]; ++j) {
      for (int cam = 0; cam < 2; ++cam) {
        if (cam == 1 && rng.uniform(0.0, 1.0) >= cfg.stereo_fraction) continue;
        if (!project(j, p_w[l], cam == 1, &uv)) continue;
        w->functions.push_back(
            std::make_unique<ReprojectionResidual>(b_meas, noisy(uv), h, j, cam, sqrt_info, w->products.get()));
        ResidualDesc d;
        d.fn = w->functions.back().get();
        d.loss = huber;
        d.num_blocks = 4;
        d.blocks[0] = {BlockKind::kPose, h};
        d.blocks[1] = {BlockKind::kPose, j};
        d.blocks[2] = {BlockKind::kExtrinsic, 0};
        d.blocks[3] = {BlockKind::kInverseDepth, l};
        w->residuals.push_back(d);
      }
    }
  }

  // IMU-like factors from the truth (plus small noise), with small random bias Jacobians.
  for (int i = 0; i + 1 < F; ++i) {
    ImuDelta d;
    d.dt_s = dt;
    d.gravity_m_s2 = g;
    const Eigen::Vector3d g_w(0.0, 0.0, -g);
    const Eigen::Matrix3d R_it = Q[i].conjugate().toRotationMatrix();
    d.alpha = R_it * (P[i + 1] - P[i] - V[i] * dt - 0.5 * g_w * dt * dt) + imu_noise * 1e-3 * rng.normal3();
    d.gamma = (Q[i].conjugate() * Q[i + 1]) * solver::so3_exp(imu_noise * 2e-4 * rng.normal3());
    d.beta = R_it * (V[i + 1] - V[i] - g_w * dt) + imu_noise * 1e-3 * rng.normal3();
    d.ba0 = ba;
    d.bg0 = bg;
    auto small = [&](double s) {
      Eigen::Matrix3d m;
      for (int a = 0; a < 3; ++a)
        for (int b = 0; b < 3; ++b) m(a, b) = s * rng.normal();
      return m;
    };
    d.J_a_ba = -0.5 * dt * dt * Eigen::Matrix3d::Identity() + small(1e-4);
    d.J_a_bg = small(1e-3);
    d.J_g_bg = -dt * Eigen::Matrix3d::Identity() + small(1e-4);
    d.J_b_ba = -dt * Eigen::Matrix3d::Identity() + small(1e-4);
    d.J_b_bg = small(1e-3);
    const double sig[5] = {2e-3, 5e-4, 4e-3, 2e-3, 2e-4};
    d.sqrt_info.setZero();
    for (int a = 0; a < 15; ++a) {
      d.sqrt_info(a, a) = 1.0 / sig[a / 3];
      for (int b = a + 1; b < 15; ++b) d.sqrt_info(a, b) = 0.05 * d.sqrt_info(a, a) * rng.normal();
    }
    w->functions.push_back(std::make_unique<ImuLikeResidual>(d));
    ResidualDesc rd;
    rd.fn = w->functions.back().get();
    rd.num_blocks = 4;
    rd.blocks[0] = {BlockKind::kPose, i};
    rd.blocks[1] = {BlockKind::kSpeedBias, i};
    rd.blocks[2] = {BlockKind::kPose, i + 1};
    rd.blocks[3] = {BlockKind::kSpeedBias, i + 1};
    w->residuals.push_back(rd);
  }

  // Initial values: truth perturbed as a sliding window sees them after propagation (1 cm,
  // 0.1 deg, 5 % inverse depth, small velocity/bias errors).
  w->poses.resize(F);
  w->speed_bias.resize(F);
  for (int i = 0; i < F; ++i) {
    const Eigen::Vector3d p = P[i] + 0.01 * rng.normal3();
    const Eigen::Quaterniond q = (Q[i] * solver::so3_exp(0.002 * rng.normal3())).normalized();
    put_pose(w->poses[i], p, q);
    for (int k = 0; k < 9; ++k)
      w->speed_bias[i][k] = w->speed_bias_true[i][k] + (k < 3 ? 0.02 : (k < 6 ? 0.005 : 0.0005)) * rng.normal();
  }
  {
    const Eigen::Vector3d p = t_bc + 0.005 * rng.normal3();
    const Eigen::Quaterniond q = (q_bc * solver::so3_exp(0.003 * rng.normal3())).normalized();
    put_pose(w->extrinsic, p, q);
  }
  w->inv_depth.resize(cfg.landmarks);
  for (int l = 0; l < cfg.landmarks; ++l)
    w->inv_depth[l] = w->inv_depth_true[l] * (1.0 + 0.05 * rng.normal());

  // Dense prior (as left by marginalizing an older frame): all poses, the first speed-bias and the
  // extrinsic, linearized at the truth with well-conditioned random information.
  if (cfg.with_prior) {
    for (int i = 0; i < F; ++i) w->prior_blocks.push_back({BlockKind::kPose, i});
    w->prior_blocks.push_back({BlockKind::kSpeedBias, 0});
    w->prior_blocks.push_back({BlockKind::kExtrinsic, 0});
    std::vector<solver::PriorBlock> pbs;
    int dim = 0;
    for (const BlockRef& br : w->prior_blocks) {
      solver::PriorBlock pb;
      const bool pose = br.kind != BlockKind::kSpeedBias;
      pb.manifold = pose ? solver::ManifoldType::kPose : solver::ManifoldType::kEuclidean;
      pb.ambient_size = pose ? 7 : 9;
      pb.tangent_size = pose ? 6 : 9;
      pb.offset = dim;
      const double* truth = br.kind == BlockKind::kPose ? w->poses_true[br.index].data()
                            : br.kind == BlockKind::kSpeedBias ? w->speed_bias_true[br.index].data()
                                                               : w->extrinsic_true.data();
      for (int k = 0; k < pb.ambient_size; ++k) pb.x_lin[k] = truth[k];
      dim += pb.tangent_size;
      pbs.push_back(pb);
    }
    Eigen::MatrixXd A(dim, dim);
    for (int r = 0; r < dim; ++r)
      for (int c = 0; c < dim; ++c) A(r, c) = 3.0 * rng.normal();
    Eigen::MatrixXd H(dim, dim);
    H.noalias() = A.transpose() * A;
    for (int k = 0; k < dim; ++k) H(k, k) += 100.0;
    Eigen::VectorXd b(dim);
    for (int k = 0; k < dim; ++k) b[k] = cfg.noise_free ? 0.0 : 5.0 * rng.normal();
    w->prior = std::make_unique<solver::MarginalPrior>();
    w->prior->set_from_information(pbs.data(), static_cast<int>(pbs.size()), H, b);
  }
  w->poses0 = w->poses;
  w->speed_bias0 = w->speed_bias;
  w->extrinsic0 = w->extrinsic;
  w->inv_depth0 = w->inv_depth;
  return w;
}

// Declares the window in `problem` (cleared first): poses, speed-biases, extrinsic, landmarks in
// that order, then residuals and the prior in the window's order. Returns kOk or the first error.
inline solver::SolverStatus add_to_problem(VioWindow& w, solver::Problem& problem) {
  problem.clear();
  const int F = static_cast<int>(w.poses.size());
  const int L = static_cast<int>(w.inv_depth.size());
  auto id_of = [&](const BlockRef& b) {
    switch (b.kind) {
      case BlockKind::kPose: return b.index;
      case BlockKind::kSpeedBias: return F + b.index;
      case BlockKind::kExtrinsic: return 2 * F;
      case BlockKind::kInverseDepth: return 2 * F + 1 + b.index;
    }
    return -1;
  };
  solver::SolverStatus s = solver::SolverStatus::kOk;
  solver::BlockId id = 0;
  for (int i = 0; i < F && s == solver::SolverStatus::kOk; ++i) s = problem.add_pose_block(w.poses[i].data(), &id);
  for (int i = 0; i < F && s == solver::SolverStatus::kOk; ++i)
    s = problem.add_euclidean_block(w.speed_bias[i].data(), 9, &id);
  if (s == solver::SolverStatus::kOk) s = problem.add_pose_block(w.extrinsic.data(), &id);
  for (int l = 0; l < L && s == solver::SolverStatus::kOk; ++l) s = problem.add_landmark_block(&w.inv_depth[l], 1, &id);
  for (const ResidualDesc& r : w.residuals) {
    if (s != solver::SolverStatus::kOk) break;
    solver::BlockId ids[4];
    for (int k = 0; k < r.num_blocks; ++k) ids[k] = id_of(r.blocks[k]);
    s = problem.add_residual(r.fn, r.loss, ids, r.num_blocks);
  }
  for (int l = 0; l < L && s == solver::SolverStatus::kOk && w.config.point_lifts; ++l) {
    const solver::BlockId ext = 2 * F;
    s = problem.set_point_lift(w.lifts[static_cast<std::size_t>(l)].get(), w.host[static_cast<std::size_t>(l)],
                               2 * F + 1 + l, &ext, 1);
  }
  if (s == solver::SolverStatus::kOk && w.prior) {
    solver::BlockId ids[solver::capacity::kMaxReducedBlocks];
    for (std::size_t k = 0; k < w.prior_blocks.size(); ++k) ids[k] = id_of(w.prior_blocks[k]);
    s = problem.add_prior(w.prior.get(), ids);
  }
  return s;
}

}  // namespace ums::bench
