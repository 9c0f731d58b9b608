// ProblemBuilder (core/estimator/problem_builder.hpp): the window's solve and the outlier check
// over the same edges.
#include "core/estimator/problem_builder.hpp"

#include <catch2/catch.hpp>
#include <cmath>
#include <vector>

#include "core/estimator/estimator_stats.hpp"
#include "core/estimator/landmark_map.hpp"
#include "core/estimator/marginalizer.hpp"
#include "tests/core/estimator/stereo_scene.hpp"

namespace {

constexpr double kFocalPx = 460.0;

struct Outcome {
  int marked = 0;
  std::vector<std::uint32_t> outlier_ids;
  ums::EstimatorStats after_solve;  // the counters right after the solve
  ums::EstimatorStats after_resolve;  // ... and after a second solve from its result
};

// Four stereo frames 0.2 m apart see 40 points 3-8 m ahead; with `planted`, point 6 (feature
// id 7) is seen 12 px off in the last frame (a tracking error). The landmarks triangulated.
void observe_points(bool planted, ums::test::StereoScene* sc, ums::LandmarkMap* map) {
  std::vector<Eigen::Vector3d> pts;
  for (int i = 0; i < 40; ++i) {
    const double u = -0.6 + 1.2 * ((i * 7) % 40) / 39.0, v = -0.4 + 0.8 * ((i * 13) % 40) / 39.0;
    const double z = 3.0 + 5.0 * ((i * 17) % 40) / 39.0;
    pts.emplace_back(u * z, v * z, z);
  }
  for (int k = 0; k < 4; ++k) {
    std::vector<Eigen::Vector3d> seen = pts;
    if (planted && k == 3) seen[6] += Eigen::Vector3d(12.0 / kFocalPx * pts[6].z(), 0.0, 0.0);
    REQUIRE(sc->add_frame(0.2 * k, seen.data(), static_cast<int>(seen.size()), true, map) >= 0);
  }
  map->triangulate_all(sc->window, -1);
}

// The scene of observe_points with the tracking error. Vision-only solve with the first pose fixed, then
// the outlier check; with `moved`, one pose is nudged by one float step after the solve, so the
// check cannot take the solver's kept residuals and evaluates the edges itself.
Outcome solve_and_check(bool moved) {
  ums::test::StereoScene sc;
  ums::LandmarkMap map{ums::LandmarkMapOptions()};
  observe_points(true, &sc, &map);
  ums::ProblemBuilderOptions opt;
  opt.weight_3d = opt.weight_2d = kFocalPx / 1.5;
  opt.huber_rad = 1.0;
  opt.outlier_rad = 3.0 / kFocalPx;
  ums::Marginalizer marginalizer;
  ums::EstimatorStats stats;
  ums::ProblemBuilder builder(opt, &sc.window, &map, &marginalizer, &stats);
  ums::SolveSpec spec;
  spec.imu = false;
  spec.prior = false;
  spec.fix_first_pose = true;
  REQUIRE(builder.solve(spec, {5}));
  REQUIRE(builder.num_selected() >= 35);
  if (moved) {
    double& x = ums::state::p(sc.window.slot(sc.window.slot_at(2)).pose).x();
    x = std::nextafter(x, 1.0);
  }
  Outcome out;
  out.after_solve = stats;
  out.marked = builder.mark_outliers();
  for (int k = 0; k < map.size(); ++k)
    if (map[k].outlier) out.outlier_ids.push_back(map[k].id);
  REQUIRE(builder.solve(spec, {5}));
  out.after_resolve = stats;
  return out;
}

// The same scene (point 6 seen 12 px off in the last frame when `planted`), a vision-only solve
// cut short at one iteration, the outlier check, then the second round by solve_again (`again`)
// or by solve: the window's poses and depths after it, and the counters.
struct RoundTwo {
  std::vector<double> state;
  ums::EstimatorStats stats;
  int marked = 0;
};
RoundTwo second_round(bool planted, bool again) {
  ums::test::StereoScene sc;
  ums::LandmarkMap map{ums::LandmarkMapOptions()};
  observe_points(planted, &sc, &map);
  // The frames start 2 cm off their true places: one iteration does not reach the optimum.
  for (int k = 1; k < 4; ++k) ums::state::p(sc.window.slot(sc.window.slot_at(k)).pose).y() += 0.02;
  ums::ProblemBuilderOptions opt;
  opt.weight_3d = opt.weight_2d = kFocalPx / 1.5;
  opt.huber_rad = 1.0;
  opt.outlier_rad = 3.0 / kFocalPx;
  ums::Marginalizer marginalizer;
  RoundTwo out;
  ums::ProblemBuilder builder(opt, &sc.window, &map, &marginalizer, &out.stats);
  ums::SolveSpec spec;
  spec.imu = false;
  spec.prior = false;
  spec.fix_first_pose = true;
  REQUIRE(builder.solve(spec, {1}));
  out.marked = builder.mark_outliers();
  if (out.marked > 0) map.compact();
  const bool usable = again ? builder.solve_again(spec, {4}) : builder.solve(spec, {4});
  REQUIRE(usable);
  for (int k = 0; k < sc.window.size(); ++k) {
    const double* pose = sc.window.slot(sc.window.slot_at(k)).pose;
    out.state.insert(out.state.end(), pose, pose + ums::state::kPoseSize);
  }
  for (int k = 0; k < map.size(); ++k) out.state.push_back(map[k].inv_depth);
  return out;
}

}  // namespace

TEST_CASE("A second round with nothing removed solves round 1's problem again, with the result of building it anew",
          "[estimator][problem_builder]") {
  const RoundTwo kept = second_round(false, true);
  const RoundTwo rebuilt = second_round(false, false);
  CHECK(kept.marked == 0);
  CHECK(kept.stats.solves == 2);
  CHECK(kept.stats.problem_builds == 1);  // the second solve took round 1's problem
  CHECK(rebuilt.stats.problem_builds == 2);
  CHECK(kept.stats.solver_iterations == rebuilt.stats.solver_iterations);
  REQUIRE(kept.state.size() == rebuilt.state.size());
  int differ = 0;
  for (std::size_t i = 0; i < kept.state.size(); ++i) differ += kept.state[i] != rebuilt.state[i] ? 1 : 0;
  CHECK(differ == 0);
  // The second round iterated (round 1 was cut short at one) and moved the window: without it,
  // 61 of the values differ.
  CHECK(kept.stats.solver_iterations >= 2);
  // With an outlier removed the problem changes: solve_again builds it anew.
  const RoundTwo removed = second_round(true, true);
  CHECK(removed.marked == 1);
  CHECK(removed.stats.problem_builds == 2);
}

TEST_CASE("The outlier check finds the planted observation, from the solve's residuals or afresh",
          "[estimator][problem_builder]") {
  const Outcome kept = solve_and_check(false);
  const Outcome fresh = solve_and_check(true);
  CHECK(kept.marked == 1);
  REQUIRE(kept.outlier_ids.size() == 1);
  CHECK(kept.outlier_ids[0] == 7u);
  CHECK(fresh.marked == kept.marked);
  CHECK(fresh.outlier_ids == kept.outlier_ids);
}

TEST_CASE("Each solve's iterations, linearizations and passes add up in the estimator's counters",
          "[estimator][problem_builder]") {
  const Outcome o = solve_and_check(false);
  const ums::EstimatorStats& a = o.after_solve;
  const ums::EstimatorStats& b = o.after_resolve;
  CHECK(a.solves == 1);
  // Five iterations at most; every iteration linearizes or takes a gradient pass, and a pass over
  // the residuals is made for each of those and for each candidate's cost.
  CHECK(a.solver_iterations >= 1);
  CHECK(a.solver_iterations <= 5);
  CHECK(a.solver_successful_steps <= a.solver_iterations);
  CHECK(a.solver_linearizations >= 1);
  CHECK(a.solver_gradient_passes <= a.solver_linearizations);
  CHECK(a.solver_factor_reuses <= a.solver_iterations);
  CHECK(a.solver_residual_passes >= a.solver_linearizations);
  // The second solve starts at the first one's optimum (with the outlier dropped): it adds.
  CHECK(b.solves == 2);
  CHECK(b.solver_iterations > a.solver_iterations);
  CHECK(b.solver_linearizations > a.solver_linearizations);
  CHECK(b.solver_residual_passes > a.solver_residual_passes);
}
