// Marginalization with kept terms (solver/problem_marginalize.cpp, set_marginalization_hint):
// the prior from the last linearization's kept landmark terms must equal the prior of a fresh
// linearization at the same values, to rounding; any change since that linearization (values,
// the list, a solve that ended on an unlinearized step) must fall back to a fresh one; a rigid
// move of the poses must be followed exactly.
#include <catch2/catch.hpp>

#include <cmath>
#include <memory>
#include <vector>

#include "profiling/alloc_counter.hpp"
#include "profiling/solver_bench/vio_window.hpp"
#include "solver/problem.hpp"

namespace ums::solver {
namespace {

struct Window {
  std::unique_ptr<bench::VioWindow> w;
  std::unique_ptr<Problem> problem = std::make_unique<Problem>();
  std::vector<BlockId> marg;  // frame 0's pose and speed-bias, the landmarks it hosts
  int F = 0;
};

Window make_window(bool lifts) {
  bench::WindowConfig cfg;
  cfg.frames = 6;
  cfg.landmarks = 60;
  cfg.max_obs = 6;
  cfg.with_prior = true;
  cfg.seed = 5;
  cfg.point_lifts = lifts;
  Window s;
  s.w = bench::make_vio_window(cfg);
  REQUIRE(bench::add_to_problem(*s.w, *s.problem) == SolverStatus::kOk);
  s.F = static_cast<int>(s.w->poses.size());
  s.marg = {0, s.F};
  for (std::size_t l = 0; l < s.w->host.size(); ++l)
    if (s.w->host[l] == 0) s.marg.push_back(2 * s.F + 1 + static_cast<int>(l));
  REQUIRE(s.marg.size() > 5);
  return s;
}

SolverSummary solve(Window& s, int max_iterations) {
  SolverOptions o;
  o.max_iterations = max_iterations;
  SolverSummary sum;
  REQUIRE(usable(s.problem->solve(o, &sum)));
  return sum;
}

// The window with frame 0's blocks hinted, solved.
Window hinted(bool lifts, int max_iterations, SolverSummary* summary = nullptr) {
  Window s = make_window(lifts);
  REQUIRE(s.problem->set_marginalization_hint(s.marg.data(), static_cast<int>(s.marg.size())) == SolverStatus::kOk);
  const SolverSummary sum = solve(s, max_iterations);
  if (summary != nullptr) *summary = sum;
  return s;
}

std::unique_ptr<MarginalPrior> marginalize(Window& s) {
  auto prior = std::make_unique<MarginalPrior>();
  REQUIRE(s.problem->marginalize(s.marg.data(), static_cast<int>(s.marg.size()), prior.get()) == SolverStatus::kOk);
  return prior;
}

// Two priors over the same blocks agree to rounding (relative to the largest information entry).
void check_same_prior(const MarginalPrior& a, const MarginalPrior& b) {
  REQUIRE(a.dim() == b.dim());
  REQUIRE(a.num_blocks() == b.num_blocks());
  for (int i = 0; i < a.num_blocks(); ++i) CHECK(a.block(i).source_id == b.block(i).source_id);
  const double scale = b.information().cwiseAbs().maxCoeff();
  CHECK(scale > 1.0);
  CHECK((a.information() - b.information()).cwiseAbs().maxCoeff() <= 1e-9 * scale);
  // The square root (J, r0) is one of many (its eigenvectors' signs): its gradient J^T r0 is not.
  const Eigen::VectorXd ga = a.sqrt_information().transpose() * a.r0();
  const Eigen::VectorXd gb = b.sqrt_information().transpose() * b.r0();
  CHECK((ga - gb).cwiseAbs().maxCoeff() <= 1e-9 * (1.0 + gb.cwiseAbs().maxCoeff()));
}

// Every pose moved by (R, t) of the world frame, velocities rotated, as Estimator::hold_gauge does.
void move_world(bench::VioWindow& w, const Eigen::Matrix3d& R, const Eigen::Vector3d& t) {
  const Eigen::Quaterniond q_R(R);
  for (auto& p : w.poses) {
    const Eigen::Vector3d pos = R * Eigen::Vector3d(p[0], p[1], p[2]) + t;
    const Eigen::Quaterniond q = q_R * Eigen::Quaterniond(p[6], p[3], p[4], p[5]);
    bench::put_pose(p, pos, q);
  }
  for (auto& sb : w.speed_bias) {
    const Eigen::Vector3d v = R * Eigen::Vector3d(sb[0], sb[1], sb[2]);
    sb[0] = v.x();
    sb[1] = v.y();
    sb[2] = v.z();
  }
}

}  // namespace

TEST_CASE("Marginalization hint: the kept terms give the prior of a fresh linearization",
          "[solver][problem][marginalization]") {
  for (const bool lifts : {false, true}) {
    INFO("point lifts " << lifts);
    SolverSummary sum;
    Window s = hinted(lifts, 10, &sum);
    CHECK(sum.termination != Termination::kMaxIterations);
    CHECK(sum.initial_cost > 5.0 * sum.final_cost);
    const auto kept = marginalize(s);
    CHECK(s.problem->marginalization_reused());
    // The same call again linearizes afresh at the same values (the first one used the terms up).
    const auto fresh = marginalize(s);
    CHECK_FALSE(s.problem->marginalization_reused());
    check_same_prior(*kept, *fresh);

    // The hinted solve reaches the unhinted one's state to rounding (its sums are grouped apart).
    Window plain = make_window(lifts);
    solve(plain, 10);
    double dx = 0.0;
    for (int i = 0; i < s.F; ++i)
      for (int k = 0; k < 7; ++k) dx = std::max(dx, std::abs(s.w->poses[i][k] - plain.w->poses[i][k]));
    CHECK(dx < 1e-9);
    const auto unhinted = marginalize(plain);
    CHECK_FALSE(plain.problem->marginalization_reused());
    check_same_prior(*kept, *unhinted);
  }
}

TEST_CASE("Marginalization hint: anything changed since the last linearization falls back",
          "[solver][problem][marginalization]") {
  SECTION("the solve ended on an accepted step it did not linearize at") {
    SolverSummary sum;
    Window s = hinted(true, 1, &sum);
    REQUIRE(sum.successful_steps == 1);
    marginalize(s);
    CHECK_FALSE(s.problem->marginalization_reused());
  }
  SECTION("the solve ended on its step budget (max_successful_steps), without linearizing there") {
    Window s = make_window(true);
    REQUIRE(s.problem->set_marginalization_hint(s.marg.data(), static_cast<int>(s.marg.size())) == SolverStatus::kOk);
    SolverOptions o;
    o.max_successful_steps = 1;
    SolverSummary sum;
    REQUIRE(usable(s.problem->solve(o, &sum)));
    REQUIRE(sum.termination == Termination::kMaxSuccessfulSteps);
    const auto after = marginalize(s);
    CHECK_FALSE(s.problem->marginalization_reused());
    const auto fresh = marginalize(s);  // the prior of a linearization at these values
    check_same_prior(*after, *fresh);
  }
  SECTION("a marginalized landmark's value moved by one ulp") {
    Window s = hinted(true, 10);
    const int l = s.marg.back() - (2 * s.F + 1);
    s.w->inv_depth[l] = std::nextafter(s.w->inv_depth[l], 1.0);
    marginalize(s);
    CHECK_FALSE(s.problem->marginalization_reused());
  }
  SECTION("the hint listed other landmarks") {
    Window s = make_window(true);
    const BlockId frame0[2] = {0, s.F};
    REQUIRE(s.problem->set_marginalization_hint(frame0, 2) == SolverStatus::kOk);
    solve(s, 10);
    marginalize(s);
    CHECK_FALSE(s.problem->marginalization_reused());
  }
  SECTION("a block made constant after the solve") {
    Window s = hinted(true, 10);
    REQUIRE(s.problem->set_constant(2 * s.F, true) == SolverStatus::kOk);  // the extrinsic
    marginalize(s);
    CHECK_FALSE(s.problem->marginalization_reused());
  }
  SECTION("a new layout prepared by another call in between (evaluate_cost)") {
    // Values and landmarks unchanged, rows moved: the terms of the old layout must not be taken.
    Window s = hinted(true, 10);
    REQUIRE(s.problem->set_constant(1, true) == SolverStatus::kOk);  // pose 1: the rows after it move
    double cost = 0.0;
    REQUIRE(s.problem->evaluate_cost(&cost) == SolverStatus::kOk);
    const auto after = marginalize(s);
    CHECK_FALSE(s.problem->marginalization_reused());
    const auto fresh = marginalize(s);
    check_same_prior(*after, *fresh);
  }
}

TEST_CASE("Marginalization hint: a rigid move of the poses after the solve is followed",
          "[solver][problem][marginalization]") {
  const Eigen::Matrix3d R = Eigen::AngleAxisd(0.3, Eigen::Vector3d::UnitZ()).toRotationMatrix() *
                            Eigen::AngleAxisd(0.1, Eigen::Vector3d::UnitX()).toRotationMatrix();
  const Eigen::Vector3d t(1.0, -2.0, 0.5);
  std::vector<BlockId> poses;
  Window s = hinted(true, 10);
  for (int i = 0; i < s.F; ++i) poses.push_back(i);
  SECTION("moved by R, noted: the kept terms rotated equal a fresh linearization there") {
    move_world(*s.w, R, t);
    REQUIRE(s.problem->note_world_moved(poses.data(), s.F, R) == SolverStatus::kOk);
    const auto kept = marginalize(s);
    CHECK(s.problem->marginalization_reused());
    const auto fresh = marginalize(s);
    check_same_prior(*kept, *fresh);
    // Not a no-op: the prior at the moved values differs from one of the unmoved window by far
    // more than rounding (the position rows turned with R).
    Window still = make_window(true);
    solve(still, 10);
    const auto unmoved = marginalize(still);
    const double scale = unmoved->information().cwiseAbs().maxCoeff();
    CHECK((kept->information() - unmoved->information()).cwiseAbs().maxCoeff() > 1e-3 * scale);
  }
  SECTION("moved but not noted, noted with another R, or one pose off the rigid move") {
    move_world(*s.w, R, t);
    SECTION("not noted") {}
    SECTION("another R") {
      const Eigen::Matrix3d R2 = Eigen::AngleAxisd(0.31, Eigen::Vector3d::UnitZ()).toRotationMatrix();
      REQUIRE(s.problem->note_world_moved(poses.data(), s.F, R2) == SolverStatus::kOk);
    }
    SECTION("one pose off") {
      s.w->poses[2][0] += 1e-6;
      REQUIRE(s.problem->note_world_moved(poses.data(), s.F, R) == SolverStatus::kOk);
    }
    marginalize(s);
    CHECK_FALSE(s.problem->marginalization_reused());
  }
}

TEST_CASE("Marginalization hint: bad ids are refused, hinted passes allocate nothing",
          "[solver][problem][marginalization]") {
  Window s = make_window(true);
  const BlockId bad[1] = {-1};
  const BlockId far[1] = {100000};
  const BlockId speed_bias[1] = {s.F};
  const Eigen::Matrix3d I = Eigen::Matrix3d::Identity();
  CHECK(s.problem->set_marginalization_hint(bad, 1) == SolverStatus::kInvalidInput);
  CHECK(s.problem->set_marginalization_hint(far, 1) == SolverStatus::kInvalidInput);
  CHECK(s.problem->set_marginalization_hint(nullptr, 1) == SolverStatus::kInvalidInput);
  CHECK(s.problem->note_world_moved(speed_bias, 1, I) == SolverStatus::kInvalidInput);
  CHECK(s.problem->note_world_moved(bad, 1, I) == SolverStatus::kInvalidInput);
  const BlockId twice[2] = {1, 1};  // it would be turned twice
  CHECK(s.problem->note_world_moved(twice, 2, I) == SolverStatus::kInvalidInput);
  CHECK(s.problem->marginalize(s.marg.data(), static_cast<int>(s.marg.size()), nullptr) == SolverStatus::kInvalidInput);
  CHECK_FALSE(s.problem->marginalization_reused());
  REQUIRE(s.problem->set_marginalization_hint(s.marg.data(), static_cast<int>(s.marg.size())) == SolverStatus::kOk);
  std::vector<BlockId> poses;
  for (int i = 0; i < s.F; ++i) poses.push_back(i);
  SolverOptions o;
  o.max_iterations = 10;
  SolverSummary sum;
  auto prior = std::make_unique<MarginalPrior>();
  AllocScope scope;
  const SolverStatus st = s.problem->solve(o, &sum);
  const SolverStatus sn = s.problem->note_world_moved(poses.data(), s.F, I);
  const SolverStatus sm = s.problem->marginalize(s.marg.data(), static_cast<int>(s.marg.size()), prior.get());
  const auto allocations = scope.allocations();
  CHECK(usable(st));
  CHECK(sn == SolverStatus::kOk);
  CHECK(sm == SolverStatus::kOk);
  CHECK(s.problem->marginalization_reused());
  if (alloc_counter_available()) CHECK(allocations == 0);
}

}  // namespace ums::solver
