#pragma once
// A hook that runs before the solver evaluates residuals at parameter values that may have changed
// since its previous evaluation: before every pass of Problem::solve() (the linearization and each
// trial point), Problem::evaluate_cost() and Problem::marginalize(). Residuals that share work
// (e.g. products of poses used by hundreds of reprojection residuals) compute it lazily and drop
// it here, once per pass instead of once per residual. It must not allocate.

namespace ums::solver {

class EvaluationCallback {
 public:
  virtual ~EvaluationCallback() = default;
  virtual void prepare_for_evaluation() = 0;
};

}  // namespace ums::solver
