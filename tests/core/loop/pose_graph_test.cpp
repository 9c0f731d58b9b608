// The 4-DoF pose graph: its residual's Jacobians against central differences, loop closure on a
// drifted circle (errors in metres and degrees against ground truth), a false loop under the
// robust loss, the full-capacity graph (2000 nodes, 500 loops) with an allocation count and its
// worst-case time, refusals, and a consistent graph that must not move.
#include "core/loop/pose_graph.hpp"

#include <catch2/catch.hpp>

#include <chrono>
#include <ctime>
#include <cmath>
#include <random>
#include <stdexcept>
#include <vector>

#include "core/math/quaternion.hpp"
#include "profiling/alloc_counter.hpp"

using namespace ums;
using namespace ums::loop;

namespace {

constexpr double kPi = 3.14159265358979323846;
constexpr double kDeg = kPi / 180.0;

Eigen::Matrix3d ypr(double yaw_rad, double pitch_rad, double roll_rad) {
  return (Eigen::AngleAxisd(yaw_rad, Eigen::Vector3d::UnitZ()) * Eigen::AngleAxisd(pitch_rad, Eigen::Vector3d::UnitY()) *
          Eigen::AngleAxisd(roll_rad, Eigen::Vector3d::UnitX()))
      .toRotationMatrix();
}

Eigen::Isometry3d make_pose(const Eigen::Matrix3d& R_w_b, const Eigen::Vector3d& p_w_b) {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = R_w_b;
  T.translation() = p_w_b;
  return T;
}

// `laps` laps of a 10 m radius circle, n_per_lap keyframes per lap (heading along the circle),
// height and roll/pitch oscillating so that the roll/pitch part matters.
std::vector<Eigen::Isometry3d> circle_truth(int n_per_lap, int laps) {
  std::vector<Eigen::Isometry3d> truth;
  for (int k = 0; k < n_per_lap * laps; ++k) {
    const double th = 2.0 * kPi * k / n_per_lap;
    const Eigen::Vector3d p(10.0 * std::cos(th), 10.0 * std::sin(th), 1.5 + 0.5 * std::sin(2.0 * th));
    truth.push_back(make_pose(ypr(th + kPi / 2, 2.0 * kDeg * std::cos(5.0 * th), 3.0 * kDeg * std::sin(3.0 * th)), p));
  }
  return truth;
}

// Dead reckoning from truth[0] with the true relative motions, each with yaw_drift_rad of extra
// heading and its translation scaled by `scale`: the 4-DoF drift of a VIO (roll and pitch stay true).
std::vector<Eigen::Isometry3d> drifted(const std::vector<Eigen::Isometry3d>& truth, double yaw_drift_rad, double scale) {
  std::vector<Eigen::Isometry3d> init{truth[0]};
  double yaw = quat::yaw(truth[0].linear());
  for (std::size_t k = 1; k < truth.size(); ++k) {
    const Eigen::Isometry3d T_rel = truth[k - 1].inverse() * truth[k];
    yaw += quat::yaw(truth[k].linear()) - quat::yaw(truth[k - 1].linear()) + yaw_drift_rad;
    const Eigen::Vector3d p = init.back() * (scale * T_rel.translation());
    init.push_back(make_pose(ypr(yaw, 0, 0) * quat::remove_yaw(truth[k].linear()), p));
  }
  return init;
}

// T_a_b perturbed: translation by n_p, yaw (about a's z) by n_yaw.
Eigen::Isometry3d perturbed(const Eigen::Isometry3d& T, const Eigen::Vector3d& n_p_m, double n_yaw_rad) {
  Eigen::Isometry3d out = T;
  out.translation() += n_p_m;
  out.linear() = ypr(n_yaw_rad, 0, 0) * T.linear();
  return out;
}

struct Errors {
  double end_m = 0.0;   // the last node's position error
  double rms_m = 0.0;   // over all nodes
  double max_m = 0.0;
  double max_yaw_deg = 0.0;
};

Errors errors(const std::vector<Eigen::Isometry3d>& est, const std::vector<Eigen::Isometry3d>& truth) {
  Errors e;
  for (std::size_t k = 0; k < truth.size(); ++k) {
    const double d = (est[k].translation() - truth[k].translation()).norm();
    e.rms_m += d * d;
    e.max_m = std::max(e.max_m, d);
    const double dyaw = quat::wrap_angle_rad(quat::yaw(est[k].linear()) - quat::yaw(truth[k].linear()));
    e.max_yaw_deg = std::max(e.max_yaw_deg, std::abs(dyaw) / kDeg);
  }
  e.rms_m = std::sqrt(e.rms_m / static_cast<double>(truth.size()));
  e.end_m = (est.back().translation() - truth.back().translation()).norm();
  return e;
}

std::vector<Eigen::Isometry3d> poses(const PoseGraph4Dof& g) {
  std::vector<Eigen::Isometry3d> out;
  for (int k = 0; k < g.num_nodes(); ++k) out.push_back(g.pose(k));
  return out;
}

constexpr double kSigmaOdoP = 0.02;             // m
constexpr double kSigmaOdoYaw = 0.1 * kDeg;     // rad
constexpr double kSigmaLoopP = 0.05;            // m
constexpr double kSigmaLoopYaw = 0.5 * kDeg;    // rad

// Nodes at `init`; odometry edges k-1 -> k from truth (plus noise of noise_p_m / noise_yaw_rad
// standard deviation when not zero).
void build_chain(PoseGraph4Dof* g, const std::vector<Eigen::Isometry3d>& truth, const std::vector<Eigen::Isometry3d>& init,
                 double noise_p_m, double noise_yaw_rad, std::uint32_t seed) {
  std::mt19937 rng(seed);
  std::normal_distribution<double> n01(0.0, 1.0);
  for (const Eigen::Isometry3d& T : init) REQUIRE(g->add_node(T, nullptr) == Status::kOk);
  for (std::size_t k = 1; k < truth.size(); ++k) {
    const Eigen::Vector3d n_p(n01(rng), n01(rng), n01(rng));
    const Eigen::Isometry3d T_rel = perturbed(truth[k - 1].inverse() * truth[k], noise_p_m * n_p, noise_yaw_rad * n01(rng));
    REQUIRE(g->add_edge(static_cast<int>(k - 1), static_cast<int>(k), T_rel, kSigmaOdoP, kSigmaOdoYaw, EdgeKind::kOdometry) ==
            Status::kOk);
  }
}

Status add_true_loop(PoseGraph4Dof* g, const std::vector<Eigen::Isometry3d>& truth, int i, int j) {
  return g->add_edge(i, j, truth[i].inverse() * truth[j], kSigmaLoopP, kSigmaLoopYaw, EdgeKind::kLoop);
}

}  // namespace

TEST_CASE("four_dof_residual: analytic Jacobians equal central differences", "[loop]") {
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  for (int trial = 0; trial < 20; ++trial) {
    const Eigen::Matrix3d R_rp_i = ypr(0.0, 0.3 * u(rng), 0.3 * u(rng));
    Pose4Dof x_i, x_j;
    x_i.p_w_b_m = 5.0 * Eigen::Vector3d(u(rng), u(rng), u(rng));
    x_j.p_w_b_m = 5.0 * Eigen::Vector3d(u(rng), u(rng), u(rng));
    x_i.yaw_rad = 3.0 * u(rng);
    x_j.yaw_rad = 3.0 * u(rng);
    RelativePose4Dof z{Eigen::Vector3d(u(rng), u(rng), u(rng)), quat::wrap_angle_rad(x_j.yaw_rad - x_i.yaw_rad + 0.1 * u(rng))};
    Eigen::Matrix4d J_i, J_j;
    four_dof_residual(x_i, R_rp_i, x_j, z, &J_i, &J_j);
    const double h = 1e-6;
    for (int c = 0; c < 4; ++c) {
      for (int which = 0; which < 2; ++which) {
        Pose4Dof plus[2] = {x_i, x_j}, minus[2] = {x_i, x_j};
        if (c < 3) {
          plus[which].p_w_b_m(c) += h;
          minus[which].p_w_b_m(c) -= h;
        } else {
          plus[which].yaw_rad += h;
          minus[which].yaw_rad -= h;
        }
        const Eigen::Vector4d num = (four_dof_residual(plus[0], R_rp_i, plus[1], z, nullptr, nullptr) -
                                     four_dof_residual(minus[0], R_rp_i, minus[1], z, nullptr, nullptr)) /
                                    (2.0 * h);
        const Eigen::Vector4d ana = which == 0 ? Eigen::Vector4d(J_i.col(c)) : Eigen::Vector4d(J_j.col(c));
        INFO("trial " << trial << " column " << c << " node " << which);
        CHECK((num - ana).norm() < 1e-7);
      }
    }
  }
}

TEST_CASE("PoseGraph4Dof: edges measured from T_i_j give residual zero at the true poses, whatever the roll/pitch", "[loop]") {
  const auto truth = circle_truth(50, 1);
  PoseGraph4Dof g;
  for (const auto& T : truth) REQUIRE(g.add_node(T, nullptr) == Status::kOk);
  REQUIRE(add_true_loop(&g, truth, 30, 7) == Status::kOk);
  REQUIRE(add_true_loop(&g, truth, 49, 0) == Status::kOk);
  REQUIRE(g.add_odometry_edge(3, 4, kSigmaOdoP, kSigmaOdoYaw) == Status::kOk);
  const PoseGraphSummary s = g.optimize(PoseGraphOptions{});
  CHECK(s.initial_cost < 1e-20);
  CHECK(s.converged);
}

TEST_CASE("PoseGraph4Dof: a loop closes a drifted circle of 200 keyframes", "[loop]") {
  const auto truth = circle_truth(200, 1);
  // 0.2 deg of heading drift per keyframe (40 deg over the lap) and 1 % scale drift.
  const auto init = drifted(truth, 0.2 * kDeg, 1.01);
  PoseGraph4Dof g;
  // Odometry with 5 mm / 0.02 deg noise per edge on top of the drift.
  build_chain(&g, truth, init, 0.005, 0.02 * kDeg, 11);
  REQUIRE(add_true_loop(&g, truth, 199, 0) == Status::kOk);
  const Errors before = errors(init, truth);
  const PoseGraphSummary s = g.optimize(PoseGraphOptions{});
  const Errors after = errors(poses(g), truth);
  INFO("circle 200: end " << before.end_m << " -> " << after.end_m << " m, rms " << before.rms_m << " -> " << after.rms_m
                          << " m, max yaw " << before.max_yaw_deg << " -> " << after.max_yaw_deg << " deg; iterations "
                          << s.iterations << " (accepted " << s.accepted << "), cg " << s.cg_iterations << " (max "
                          << s.max_cg_iterations_used << "), cost " << s.initial_cost << " -> " << s.final_cost);
  CHECK(s.converged);
  CHECK(before.end_m > 5.0);
  CHECK(after.end_m < 0.03);
  CHECK(after.rms_m < before.rms_m / 5.0);
  CHECK(after.max_yaw_deg < 0.5);
  // Roll and pitch are not optimized: each node keeps the ones it was added with.
  for (int k = 0; k < g.num_nodes(); ++k) {
    const Eigen::Matrix3d rp_before = quat::remove_yaw(init[k].linear());
    const Eigen::Matrix3d rp_after = quat::remove_yaw(g.pose(k).linear());
    INFO("node " << k);
    CHECK((rp_after - rp_before).cwiseAbs().maxCoeff() < 1e-12);
  }
}

namespace {

// The drifted circle with the true loop 199 -> 0 and a second loop 150 -> 50 (nodes 20 m apart),
// true or with its translation wrong by 5 m (a false place-recognition match).
std::vector<Eigen::Isometry3d> solve_circle_with_loops(bool false_loop, const PoseGraphOptions& options,
                                                       PoseGraphSummary* s) {
  const auto truth = circle_truth(200, 1);
  PoseGraph4Dof g;
  build_chain(&g, truth, drifted(truth, 0.2 * kDeg, 1.01), 0.005, 0.02 * kDeg, 11);
  REQUIRE(add_true_loop(&g, truth, 199, 0) == Status::kOk);
  Eigen::Isometry3d T_150_50 = truth[150].inverse() * truth[50];
  if (false_loop) T_150_50.translation() += Eigen::Vector3d(3.0, 4.0, 0.0);
  REQUIRE(g.add_edge(150, 50, T_150_50, kSigmaLoopP, kSigmaLoopYaw, EdgeKind::kLoop) == Status::kOk);
  *s = g.optimize(options);
  return poses(g);
}

}  // namespace

TEST_CASE("PoseGraph4Dof: a loop 5 m wrong beside true ones moves the result < 5 cm under the Cauchy loss", "[loop]") {
  const auto truth = circle_truth(200, 1);
  PoseGraphOptions options;  // Cauchy, scale 1 (whitened)
  PoseGraphSummary s_true, s_false;
  const auto with_true = solve_circle_with_loops(false, options, &s_true);
  const auto with_false = solve_circle_with_loops(true, options, &s_false);
  const Errors e_true = errors(with_true, truth);
  const Errors e_false = errors(with_false, truth);
  const Errors shift = errors(with_false, with_true);
  // Without a robust loss the false loop drags the circle by metres: the loss is what helps.
  options.loop_loss = solver::LossType::kTrivial;
  PoseGraphSummary s_plain, s_huber;
  const Errors shift_plain = errors(solve_circle_with_loops(true, options, &s_plain), with_true);
  // Huber's pull on the outlier stays constant where Cauchy's fades.
  options.loop_loss = solver::LossType::kHuber;
  const Errors shift_huber = errors(solve_circle_with_loops(true, options, &s_huber), with_true);
  INFO("true loops: rms " << e_true.rms_m << " m; with the false loop: rms " << e_false.rms_m << " m, shift max "
                          << shift.max_m << " m / " << shift.max_yaw_deg << " deg (least squares: " << shift_plain.max_m
                          << " m / " << shift_plain.max_yaw_deg << " deg, Huber: " << shift_huber.max_m << " m / "
                          << shift_huber.max_yaw_deg << " deg); iterations " << s_false.iterations);
  CHECK(s_true.converged);
  CHECK(s_false.converged);
  CHECK(e_true.rms_m < 0.05);
  CHECK(shift.max_m < 0.05);
  CHECK(shift.max_yaw_deg < 0.25);
  CHECK(e_false.rms_m < 0.06);
  CHECK(shift_plain.max_m > 1.0);
  CHECK(shift.max_m < shift_huber.max_m);
}

namespace {

// 10 laps of 200 keyframes on the same circle (2000 nodes, 1999 odometry edges from truth) and
// kMaxLoopEdges loops, each from a keyframe to the one at the same place a lap earlier.
void build_full(PoseGraph4Dof* g, const std::vector<Eigen::Isometry3d>& truth, const std::vector<Eigen::Isometry3d>& init) {
  build_chain(g, truth, init, 0.0, 0.0, 0);
  const int n_loops = static_cast<int>(capacity::kMaxLoopEdges);
  for (int m = 0; m < n_loops; ++m) {
    const int k = 200 + (1800 * m) / n_loops;
    REQUIRE(add_true_loop(g, truth, k, k - 200) == Status::kOk);
  }
}

double time_ms(PoseGraph4Dof* g, const PoseGraphOptions& options, PoseGraphSummary* s) {
  const auto t0 = std::chrono::steady_clock::now();
  *s = g->optimize(options);
  return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
}

}  // namespace

TEST_CASE("PoseGraph4Dof: 2000 nodes and 500 loops converge within the CG cap, allocating nothing", "[loop]") {
  const auto truth = circle_truth(200, 10);
  const auto init = drifted(truth, 0.02 * kDeg, 1.005);  // 40 deg and 0.5 % over 2000 keyframes
  PoseGraph4Dof g;
  build_full(&g, truth, init);
  REQUIRE(g.num_nodes() == PoseGraph4Dof::kMaxNodes);
  REQUIRE(g.num_edges() == PoseGraph4Dof::kMaxEdges - 1);
  PoseGraphSummary s;
  AllocScope scope;
  const double ms = time_ms(&g, PoseGraphOptions{}, &s);
  const auto allocations = scope.allocations();
  if (alloc_counter_available()) CHECK(allocations == 0);
  const Errors before = errors(init, truth);
  const Errors after = errors(poses(g), truth);
  INFO("2000 nodes, 500 loops: max error " << before.max_m << " -> " << after.max_m << " m, max yaw error "
                                           << before.max_yaw_deg << " -> " << after.max_yaw_deg << " deg; iterations "
                                           << s.iterations << ", CG " << s.cg_iterations << " (at most "
                                           << s.max_cg_iterations_used << " per step), " << ms << " ms; footprint "
                                           << g.footprint_bytes() << " bytes");
  CHECK(s.converged);
  CHECK(s.status == Status::kOk);
  CHECK(before.max_m > 5.0);
  CHECK(after.max_m < 1e-6);  // the edges are exact: the optimum is the truth
  CHECK(after.max_yaw_deg < 1e-6);
}

TEST_CASE("PoseGraph4Dof: worst-case time at 2000 nodes, every LM step running the full CG cap", "[loop][slow]") {
  const auto truth = circle_truth(200, 10);
  const auto init = drifted(truth, 0.02 * kDeg, 1.005);
  PoseGraphOptions options;
  options.cg_relative_tolerance = 0.0;  // never stop early: max_iterations x max_cg_iterations
  options.function_tolerance = 0.0;
  options.step_tolerance = 0.0;
  double worst_ms = 0.0, worst_cpu_ms = 0.0;  // wall clock, and this process's CPU time (less
                                              // sensitive to other load on the machine)
  PoseGraphSummary s;
  for (int run = 0; run < 3; ++run) {
    PoseGraph4Dof g;
    build_full(&g, truth, init);
    const std::clock_t c0 = std::clock();
    worst_ms = std::max(worst_ms, time_ms(&g, options, &s));
    worst_cpu_ms = std::max(worst_cpu_ms, 1000.0 * static_cast<double>(std::clock() - c0) / CLOCKS_PER_SEC);
  }
  WARN("worst case, 2000 nodes + 500 loops, " << s.iterations << " LM steps x " << s.max_cg_iterations_used
                                              << " CG iterations: " << worst_ms << " ms wall, " << worst_cpu_ms
                                              << " ms CPU (slowest of 3)");
  CHECK(s.iterations == options.max_iterations);
  CHECK(s.cg_iterations <= options.max_iterations * options.max_cg_iterations);
}

TEST_CASE("PoseGraph4Dof: block-Jacobi PCG reaches the same solution with >5x (measured ~14x) the CG iterations", "[loop][slow]") {
  const auto truth = circle_truth(200, 10);
  const auto init = drifted(truth, 0.02 * kDeg, 1.005);
  PoseGraphOptions options;
  PoseGraphSummary s_chain, s_jacobi;
  PoseGraph4Dof chain;
  build_full(&chain, truth, init);
  const double ms_chain = time_ms(&chain, options, &s_chain);
  options.preconditioner = PoseGraphPreconditioner::kBlockJacobi;
  options.max_cg_iterations = 5000;
  PoseGraph4Dof jacobi;
  build_full(&jacobi, truth, init);
  const double ms_jacobi = time_ms(&jacobi, options, &s_jacobi);
  INFO("chain: CG " << s_chain.cg_iterations << " (max " << s_chain.max_cg_iterations_used << "), " << ms_chain
                    << " ms; block Jacobi: CG " << s_jacobi.cg_iterations << " (max " << s_jacobi.max_cg_iterations_used
                    << "), " << ms_jacobi << " ms");
  CHECK(s_jacobi.converged);
  CHECK(errors(poses(jacobi), poses(chain)).max_m < 1e-6);
  CHECK(s_jacobi.cg_iterations > 5 * s_chain.cg_iterations);
}

TEST_CASE("PoseGraph4Dof: kFull over capacity, bad indices and inputs refused", "[loop]") {
  PoseGraph4Dof g;
  int index = -1;
  for (int k = 0; k < PoseGraph4Dof::kMaxNodes; ++k) {
    REQUIRE(g.add_node(make_pose(Eigen::Matrix3d::Identity(), Eigen::Vector3d(k, 0, 0)), &index) == Status::kOk);
    REQUIRE(index == k);
  }
  CHECK(g.add_node(Eigen::Isometry3d::Identity(), &index) == Status::kFull);
  CHECK(g.num_nodes() == PoseGraph4Dof::kMaxNodes);
  for (int k = 0; k < PoseGraph4Dof::kMaxEdges; ++k)
    REQUIRE(g.add_odometry_edge(k % (PoseGraph4Dof::kMaxNodes - 1), k % (PoseGraph4Dof::kMaxNodes - 1) + 1, 0.1, 0.01) ==
            Status::kOk);
  CHECK(g.add_odometry_edge(0, 1, 0.1, 0.01) == Status::kFull);
  CHECK(g.num_edges() == PoseGraph4Dof::kMaxEdges);

  g.clear();
  CHECK(g.optimize(PoseGraphOptions{}).status == Status::kNotEnoughData);
  REQUIRE(g.add_node(Eigen::Isometry3d::Identity(), nullptr) == Status::kOk);
  REQUIRE(g.add_node(Eigen::Isometry3d::Identity(), nullptr) == Status::kOk);
  const Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  CHECK(g.add_edge(0, 2, T, 0.1, 0.01, EdgeKind::kLoop) == Status::kInvalidInput);
  CHECK(g.add_edge(-1, 1, T, 0.1, 0.01, EdgeKind::kLoop) == Status::kInvalidInput);
  CHECK(g.add_edge(1, 1, T, 0.1, 0.01, EdgeKind::kLoop) == Status::kInvalidInput);
  CHECK(g.add_edge(0, 1, T, 0.0, 0.01, EdgeKind::kLoop) == Status::kInvalidInput);
  CHECK(g.add_edge(0, 1, T, 0.1, std::nan(""), EdgeKind::kLoop) == Status::kInvalidInput);
  Eigen::Isometry3d bad = T;
  bad.translation().x() = std::nan("");
  CHECK(g.add_edge(0, 1, bad, 0.1, 0.01, EdgeKind::kLoop) == Status::kInvalidInput);
  CHECK(g.add_node(bad, nullptr) == Status::kInvalidInput);
  CHECK(g.add_odometry_edge(0, 5, 0.1, 0.01) == Status::kInvalidInput);
  CHECK(g.set_fixed(2, true) == Status::kInvalidInput);
  CHECK(g.num_nodes() == 2);
  CHECK(g.num_edges() == 0);
  PoseGraphOptions options;
  options.max_cg_iterations = 0;
  CHECK_THROWS_AS(options.validate(), std::invalid_argument);
}

TEST_CASE("PoseGraph4Dof: with consistent edges (no drift) nothing moves", "[loop]") {
  const auto truth = circle_truth(100, 2);
  PoseGraph4Dof g;
  for (const auto& T : truth) REQUIRE(g.add_node(T, nullptr) == Status::kOk);
  for (int k = 1; k < g.num_nodes(); ++k) REQUIRE(g.add_odometry_edge(k - 1, k, kSigmaOdoP, kSigmaOdoYaw) == Status::kOk);
  for (int k = 100; k < 200; k += 7) REQUIRE(add_true_loop(&g, truth, k, k - 100) == Status::kOk);
  const PoseGraphSummary s = g.optimize(PoseGraphOptions{});
  CHECK(s.converged);
  const Errors e = errors(poses(g), truth);
  CHECK(e.max_m < 1e-9);
  CHECK(e.max_yaw_deg < 1e-9);
}

TEST_CASE("PoseGraph4Dof: set_fixed moves the gauge to another node, which then stays exactly put", "[loop]") {
  const auto truth = circle_truth(200, 1);
  const auto init = drifted(truth, 0.2 * kDeg, 1.01);
  PoseGraph4Dof g;
  build_chain(&g, truth, init, 0.0, 0.0, 0);
  REQUIRE(add_true_loop(&g, truth, 199, 0) == Status::kOk);
  REQUIRE(g.set_fixed(0, false) == Status::kOk);
  REQUIRE(g.set_fixed(100, true) == Status::kOk);
  const PoseGraphSummary s = g.optimize(PoseGraphOptions{});
  CHECK(s.converged);
  CHECK(g.pose(100).translation() == init[100].translation());
  CHECK(g.state(100).yaw_rad == quat::yaw(init[100].linear()));
  // Exact edges: the solution is the truth moved rigidly (4 dof) so that node 100 sits at init[100].
  const Eigen::Isometry3d T_fix = init[100] * truth[100].inverse();
  std::vector<Eigen::Isometry3d> expected;
  for (const auto& T : truth) expected.push_back(T_fix * T);
  const Errors e = errors(poses(g), expected);
  CHECK(e.max_m < 1e-6);
  CHECK(e.max_yaw_deg < 1e-6);
}
