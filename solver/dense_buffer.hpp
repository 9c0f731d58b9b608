#pragma once
// Inline storage for a dense matrix of at most MaxRows x MaxCols doubles, used through an
// Eigen::Map view. Eigen refuses fixed-capacity matrices above EIGEN_STACK_ALLOCATION_LIMIT
// (128 KB), and the reduced system (192 x 192 = 288 KB) is above it; raising the limit globally
// would also let Eigen alloca() that much for temporaries everywhere. So big buffers live here,
// inside objects created once at start-up.

#include <Eigen/Core>

namespace ums::solver {

using MatrixMap = Eigen::Map<Eigen::MatrixXd>;
using ConstMatrixMap = Eigen::Map<const Eigen::MatrixXd>;

template <int MaxRows, int MaxCols>
class DenseBuffer {
 public:
  static constexpr int kMaxRows = MaxRows;
  static constexpr int kMaxCols = MaxCols;

  // Sizes within capacity (callers check capacities first); contents are left as they are.
  void resize(int rows, int cols) {
    rows_ = rows < 0 ? 0 : (rows > MaxRows ? MaxRows : rows);
    cols_ = cols < 0 ? 0 : (cols > MaxCols ? MaxCols : cols);
  }
  int rows() const { return rows_; }
  int cols() const { return cols_; }
  MatrixMap m() { return MatrixMap(data_, rows_, cols_); }
  ConstMatrixMap m() const { return ConstMatrixMap(data_, rows_, cols_); }

 private:
  alignas(64) double data_[MaxRows * MaxCols] = {};
  int rows_ = 0;
  int cols_ = 0;
};

}  // namespace ums::solver
