#pragma once
// The interface the estimator implements for each residual kind (IMU, stereo and mono
// reprojection, priors of its own). A residual returns its rows already whitened
// (sqrt_information * r) and, on request, analytic Jacobians with respect to the *tangent* of each
// parameter block (pose: 6 columns, see manifold.hpp), written row-major into caller storage.

#include <Eigen/Core>
#include <type_traits>

namespace ums::solver {

// Caller storage for d_r_d_delta of one parameter block: rows = num_residuals(), columns = the
// block's tangent size, row-major, rows row_stride doubles apart. data == nullptr: not wanted
// (constant block or cost-only evaluation).
struct JacobianView {
  double* data = nullptr;
  int row_stride = 0;
  // Set only for a residual whose supports_point_jacobian() is true, at the position of its
  // landmark's lift host (PointLift): write d r / d point (rows x 3) here instead of d r / d block;
  // the landmark's own view is then not wanted.
  bool point = false;
  bool wanted() const { return data != nullptr; }
};

// Fixed-size view over a JacobianView, for writing a block with Eigen expressions:
//   if (jac[0].wanted()) jacobian_map<2, 6>(jac[0]) = d_r_d_pose_i;
template <int R, int C>
using JacobianMap =
    Eigen::Map<Eigen::Matrix<double, R, C, (C == 1 && R != 1) ? Eigen::ColMajor : Eigen::RowMajor>,
               0, Eigen::Stride<Eigen::Dynamic, Eigen::Dynamic>>;

template <int R, int C>
JacobianMap<R, C> jacobian_map(const JacobianView& j) {
  if constexpr (C == 1 && R != 1) {
    return JacobianMap<R, C>(j.data, R, C, Eigen::Stride<Eigen::Dynamic, Eigen::Dynamic>(R * j.row_stride, j.row_stride));
  } else {
    return JacobianMap<R, C>(j.data, R, C, Eigen::Stride<Eigen::Dynamic, Eigen::Dynamic>(j.row_stride, 1));
  }
}

class ResidualFunction {
 public:
  virtual ~ResidualFunction() = default;

  // Rows of this residual (at most capacity::kMaxResidualSize).
  virtual int num_residuals() const = 0;

  // parameters[i] points at the ambient values of the i-th block given to Problem::add_residual.
  // Writes num_residuals() whitened values into residuals and every wanted jacobians[i].
  // Returns false when the residual cannot be evaluated here (e.g. a point behind the camera);
  // the solver treats that like a non-finite value. Must not allocate.
  virtual bool evaluate(const double* const* parameters, double* residuals,
                        const JacobianView* jacobians) const = 0;

  // True: evaluate() honours JacobianView::point (see PointLift).
  virtual bool supports_point_jacobian() const { return false; }
};

// A landmark seen through a point: every residual of the landmark depends on the landmark block
// and on one reduced block, its host (e.g. the pose of the frame the landmark is anchored in), only
// through a 3-vector p(host, landmark) (e.g. the landmark in the world), so its Jacobians with
// respect to the two are A * G with A = d r / d p (rows x 3) per residual and G = d p / d (host,
// landmark) shared. The solver then sums A^T A, A^T r and A^T J_c per landmark and forms the host
// and landmark blocks from G once per landmark and pass instead of once per residual
// (docs/solver.md, "Landmarks seen through a point"). Problem::set_point_lift declares it.
class PointLift {
 public:
  virtual ~PointLift() = default;
  // parameters: the values of the host, the landmark and the other blocks given to
  // Problem::set_point_lift, in that order. Writes G = d p / d (host tangent, landmark tangent),
  // 3 rows, row-major. false: not evaluable here (the pass fails as for a residual).
  virtual bool evaluate(const double* const* parameters, double* G) const = 0;
};

}  // namespace ums::solver
