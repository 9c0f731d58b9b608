// Landmarks seen through a point (solver/problem_lift.cpp): the same window linearized through
// each landmark's point and plainly must give the same solve and the same marginal prior, to
// rounding; a wrong lift must show.
#include <catch2/catch.hpp>

#include <algorithm>
#include <memory>
#include <vector>

#include "profiling/alloc_counter.hpp"
#include "profiling/solver_bench/vio_window.hpp"
#include "solver/problem.hpp"

namespace ums::solver {
namespace {

bench::WindowConfig window(bool lifts) {
  bench::WindowConfig cfg;
  cfg.frames = 6;
  cfg.landmarks = 60;
  cfg.max_obs = 6;
  cfg.with_prior = true;
  cfg.seed = 11;
  cfg.point_lifts = lifts;
  return cfg;
}

// Every block's ambient values after a solve, in add_to_problem's order.
std::vector<double> state(const bench::VioWindow& w) {
  std::vector<double> s;
  for (const auto& p : w.poses) s.insert(s.end(), p.begin(), p.end());
  for (const auto& sb : w.speed_bias) s.insert(s.end(), sb.begin(), sb.end());
  s.insert(s.end(), w.extrinsic.begin(), w.extrinsic.end());
  s.insert(s.end(), w.inv_depth.begin(), w.inv_depth.end());
  return s;
}

double max_abs_diff(const std::vector<double>& a, const std::vector<double>& b) {
  double m = 0.0;
  for (std::size_t i = 0; i < a.size(); ++i) m = std::max(m, std::abs(a[i] - b[i]));
  return m;
}

struct Solved {
  std::unique_ptr<bench::VioWindow> w;
  std::unique_ptr<Problem> problem = std::make_unique<Problem>();
  SolverSummary summary;
};

// replace_first: landmark 0 alone is seen through this lift (with lifts = false).
Solved solve_window(bool lifts, int max_iterations, const PointLift* replace_first = nullptr) {
  Solved s;
  s.w = bench::make_vio_window(window(lifts));
  REQUIRE(bench::add_to_problem(*s.w, *s.problem) == SolverStatus::kOk);
  if (replace_first != nullptr) {
    const int F = static_cast<int>(s.w->poses.size());
    const BlockId ext = 2 * F;
    REQUIRE(s.problem->set_point_lift(replace_first, s.w->host[0], 2 * F + 1, &ext, 1) == SolverStatus::kOk);
  }
  SolverOptions o;
  o.max_iterations = max_iterations;
  REQUIRE(usable(s.problem->solve(o, &s.summary)));
  return s;
}

// G of landmark 0's true lift with its inverse-depth column off by 10 %.
class SkewedLift final : public PointLift {
 public:
  explicit SkewedLift(const PointLift* lift) : lift_(lift) {}
  bool evaluate(const double* const* x, double* G) const override {
    if (!lift_->evaluate(x, G)) return false;
    for (int k = 0; k < 3; ++k) G[7 * k + 6] *= 1.1;
    return true;
  }

 private:
  const PointLift* lift_;
};

}  // namespace

TEST_CASE("Point-lifted landmarks: the solve equals the plain linearization's to rounding",
          "[solver][problem][lift]") {
  Solved plain = solve_window(false, 10);
  Solved lifted = solve_window(true, 10);
  CHECK(lifted.summary.iterations == plain.summary.iterations);
  CHECK(lifted.summary.successful_steps == plain.summary.successful_steps);
  // The solve moves the state by centimetres and the cost by orders of magnitude: equal to 1e-9
  // is equal to rounding, not "both stayed put".
  CHECK(plain.summary.initial_cost > 10.0 * plain.summary.final_cost);
  CHECK(std::abs(lifted.summary.final_cost - plain.summary.final_cost) <= 1e-12 * plain.summary.final_cost);
  CHECK(max_abs_diff(state(*lifted.w), state(*plain.w)) < 1e-9);
  CHECK(max_abs_diff(state(*plain.w), [&] {
          auto w0 = bench::make_vio_window(window(false));
          return state(*w0);
        }()) > 1e-3);
}

TEST_CASE("Point-lifted landmarks: the marginal prior equals the plain linearization's to rounding",
          "[solver][problem][lift][marginalization]") {
  Solved plain = solve_window(false, 3);
  Solved lifted = solve_window(true, 3);
  const int F = static_cast<int>(plain.w->poses.size());
  std::vector<BlockId> marg = {0, F};
  for (std::size_t l = 0; l < plain.w->host.size(); ++l)
    if (plain.w->host[l] == 0) marg.push_back(2 * F + 1 + static_cast<int>(l));
  REQUIRE(marg.size() > 5);
  auto prior_plain = std::make_unique<MarginalPrior>();
  auto prior_lifted = std::make_unique<MarginalPrior>();
  REQUIRE(plain.problem->marginalize(marg.data(), static_cast<int>(marg.size()), prior_plain.get()) == SolverStatus::kOk);
  REQUIRE(lifted.problem->marginalize(marg.data(), static_cast<int>(marg.size()), prior_lifted.get()) ==
          SolverStatus::kOk);
  REQUIRE(prior_lifted->dim() == prior_plain->dim());
  REQUIRE(prior_lifted->num_blocks() == prior_plain->num_blocks());
  const double scale = prior_plain->information().cwiseAbs().maxCoeff();
  CHECK(scale > 1.0);
  CHECK((prior_lifted->information() - prior_plain->information()).cwiseAbs().maxCoeff() <= 1e-9 * scale);
}

TEST_CASE("Point-lifted landmarks: a wrong lift moves the solution, a constant host is not lifted",
          "[solver][problem][lift]") {
  Solved plain = solve_window(false, 10);
  REQUIRE(plain.summary.successful_steps > 0);
  SECTION("G's inverse-depth column 10 % off for one landmark") {
    auto w = bench::make_vio_window(window(true));
    SkewedLift skewed(w->lifts[0].get());
    Solved wrong = solve_window(false, 10, &skewed);
    CHECK(max_abs_diff(state(*wrong.w), state(*plain.w)) > 1e-6);
  }
  SECTION("host frame constant: its landmarks are linearized plainly, the rest through the point") {
    auto run = [](bool lifts) {
      Solved s;
      s.w = bench::make_vio_window(window(lifts));
      REQUIRE(bench::add_to_problem(*s.w, *s.problem) == SolverStatus::kOk);
      REQUIRE(s.problem->set_constant(s.w->host[0], true) == SolverStatus::kOk);
      SolverOptions o;
      o.max_iterations = 3;
      REQUIRE(usable(s.problem->solve(o, &s.summary)));
      return state(*s.w);
    };
    CHECK(max_abs_diff(run(true), run(false)) < 1e-9);
  }
}

TEST_CASE("Point-lifted landmarks: bad declarations are refused, passes allocate nothing",
          "[solver][problem][lift]") {
  auto w = bench::make_vio_window(window(false));
  auto problem = std::make_unique<Problem>();
  REQUIRE(bench::add_to_problem(*w, *problem) == SolverStatus::kOk);
  const int F = static_cast<int>(w->poses.size());
  const BlockId ext = 2 * F, lm = 2 * F + 1;
  const PointLift* lift = w->lifts[0].get();
  CHECK(problem->set_point_lift(nullptr, 0, lm, &ext, 1) == SolverStatus::kInvalidInput);
  CHECK(problem->set_point_lift(lift, lm, lm, &ext, 1) == SolverStatus::kInvalidInput);  // host eliminated
  CHECK(problem->set_point_lift(lift, 0, 1, &ext, 1) == SolverStatus::kInvalidInput);    // not a landmark
  CHECK(problem->set_point_lift(lift, 0, lm, &ext, 9) == SolverStatus::kInvalidInput);   // too many blocks
  REQUIRE(problem->set_point_lift(lift, w->host[0], lm, &ext, 1) == SolverStatus::kOk);
  CHECK(problem->set_point_lift(lift, w->host[0], lm, &ext, 1) == SolverStatus::kInvalidInput);  // twice

  Solved lifted = solve_window(true, 2);
  SolverOptions o;
  o.max_iterations = 3;
  SolverSummary sum;
  std::vector<BlockId> marg = {0, F};
  for (std::size_t l = 0; l < lifted.w->host.size(); ++l)
    if (lifted.w->host[l] == 0) marg.push_back(2 * F + 1 + static_cast<int>(l));
  auto prior = std::make_unique<MarginalPrior>();
  AllocScope scope;
  const SolverStatus st = lifted.problem->solve(o, &sum);
  const SolverStatus sm = lifted.problem->marginalize(marg.data(), static_cast<int>(marg.size()), prior.get());
  const auto allocations = scope.allocations();
  CHECK(usable(st));
  CHECK(sm == SolverStatus::kOk);
  if (alloc_counter_available()) CHECK(allocations == 0);
}

}  // namespace ums::solver
