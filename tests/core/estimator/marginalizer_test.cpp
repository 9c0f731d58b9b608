#include "core/estimator/marginalizer.hpp"

#include <catch2/catch.hpp>
#include <memory>

#include "core/estimator/window.hpp"
#include "solver/marginal_prior.hpp"
#include "solver/problem.hpp"

namespace {

using Matrix9 = Eigen::Matrix<double, 9, 9>;
using Vector9 = Eigen::Matrix<double, 9, 1>;

// Linear test residual r = A_i x_i + A_j x_j - c between two speed-bias blocks (9 rows): its
// Hessian is exact, so the marginal prior must equal the dense Schur complement.
class LinearPair final : public ums::solver::ResidualFunction {
 public:
  LinearPair(const Matrix9& Ai, const Matrix9& Aj, const Vector9& c) : Ai_(Ai), Aj_(Aj), c_(c) {}
  int num_residuals() const override { return 9; }
  bool evaluate(const double* const* x, double* r, const ums::solver::JacobianView* jac) const override {
    Eigen::Map<Vector9> res(r);
    res = Ai_ * Eigen::Map<const Vector9>(x[0]) + Aj_ * Eigen::Map<const Vector9>(x[1]) - c_;
    if (jac != nullptr && jac[0].wanted()) ums::solver::jacobian_map<9, 9>(jac[0]) = Ai_;
    if (jac != nullptr && jac[1].wanted()) ums::solver::jacobian_map<9, 9>(jac[1]) = Aj_;
    return true;
  }
  Matrix9 Ai_, Aj_;
  Vector9 c_;
};

Matrix9 random_matrix(int seed) {
  std::srand(static_cast<unsigned>(seed));
  return Matrix9::Random() + 3.0 * Matrix9::Identity();
}

// Schur complement of a dense H over its first `marg` rows and columns.
Eigen::MatrixXd schur(const Eigen::MatrixXd& H, int marg) {
  const int k = static_cast<int>(H.rows()) - marg;
  const Eigen::MatrixXd Hmm = H.topLeftCorner(marg, marg);
  return H.bottomRightCorner(k, k) - H.bottomLeftCorner(k, marg) * Hmm.inverse() * H.topRightCorner(marg, k);
}

ums::WindowFrame& push(ums::Window* w) {
  ums::WindowFrame& f = w->next();
  w->push_next();
  w->choose_next_slot();
  return f;
}

}  // namespace

TEST_CASE("Marginalizer: prior blocks named by FrameId, equal to the dense marginalization, across slot reuse",
          "[estimator][marginalizer]") {
  ums::Window window{ums::PreintegrationOptions()};
  ums::WindowFrame& fa = push(&window);
  ums::WindowFrame& fb = push(&window);
  ums::WindowFrame& fc = push(&window);
  const ums::FrameId a = fa.id, b = fb.id, c = fc.id;
  for (int i = 0; i < 9; ++i) fa.sb[i] = 0.1 * i, fb.sb[i] = -0.05 * i, fc.sb[i] = 0.02 * i;
  const LinearPair ab(random_matrix(1), random_matrix(2), Vector9::Constant(0.3));
  const LinearPair ac(random_matrix(3), random_matrix(4), Vector9::Constant(-0.2));
  const Matrix9 W0 = random_matrix(5);  // a prior on A alone (gauge)
  const LinearPair a_only(W0, Matrix9::Zero(), Vector9::Zero());

  auto problem = std::make_unique<ums::solver::Problem>();
  ums::BlockTable table;
  int id[3];
  ums::WindowFrame* frames[3] = {&fa, &fb, &fc};
  for (int k = 0; k < 3; ++k) {
    problem->add_euclidean_block(frames[k]->sb, 9, &id[k]);
    table.note(id[k], ums::BlockKind::kSpeedBias, frames[k]->id);
  }
  problem->add_residual(&ab, ums::solver::RobustLoss::trivial(), {id[0], id[1]});
  problem->add_residual(&ac, ums::solver::RobustLoss::trivial(), {id[0], id[2]});
  problem->add_residual(&a_only, ums::solver::RobustLoss::trivial(), {id[0], id[1]});

  // Dense reference: H = J^T J of the three residuals over [A B C] (A couples to B and to C).
  Eigen::MatrixXd J = Eigen::MatrixXd::Zero(27, 27);
  J.block(0, 0, 9, 9) = ab.Ai_;
  J.block(0, 9, 9, 9) = ab.Aj_;
  J.block(9, 0, 9, 9) = ac.Ai_;
  J.block(9, 18, 9, 9) = ac.Aj_;
  J.block(18, 0, 9, 9) = W0;
  const Eigen::MatrixXd H = J.transpose() * J;

  ums::Marginalizer marg;
  int out[1] = {id[0]};
  REQUIRE(marg.adopt(*problem, table, out, 1));
  REQUIRE(marg.num_blocks() == 2);
  CHECK(marg.name(0).owner == b);
  CHECK(marg.name(1).owner == c);
  const Eigen::MatrixXd H_bc = schur(H, 9);
  CHECK((Eigen::MatrixXd(marg.prior()->information()) - H_bc).norm() < 1e-8 * H_bc.norm());

  // A leaves the window; a new frame D takes its slot: the prior still names B and C.
  window.erase(0);
  window.choose_next_slot();
  ums::WindowFrame& fd = push(&window);
  CHECK(&fd == &fa);  // the recycled slot
  CHECK(fd.id != a);
  // B is dropped from the prior alone: what remains is C, the dense marginalization of A and B.
  REQUIRE(marg.marginalize_frame(b, window, *problem, &table));
  REQUIRE(marg.num_blocks() == 1);
  CHECK(marg.name(0).kind == ums::BlockKind::kSpeedBias);
  CHECK(marg.name(0).owner == c);
  const Eigen::MatrixXd H_c = schur(H, 18);
  CHECK((Eigen::MatrixXd(marg.prior()->information()) - H_c).norm() < 1e-8 * H_c.norm());
  // A frame the prior does not hold: nothing to do.
  CHECK(marg.marginalize_frame(fd.id, window, *problem, &table));
  CHECK(marg.num_blocks() == 1);
}
