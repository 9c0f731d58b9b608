#include "core/frontend/epipolar_ransac.hpp"

#include <cmath>
#include <stdexcept>
#include <string>

#include <Eigen/Eigenvalues>
#include <Eigen/SVD>

#include "core/common/capacity.hpp"

namespace ums {

void RansacOptions::validate() const {
  if (iterations < 1 || iterations > 10000) {
    throw std::invalid_argument("RansacOptions.iterations must be in 1..10000, got " + std::to_string(iterations));
  }
  if (!(threshold_px > 0.0f)) {
    throw std::invalid_argument("RansacOptions.threshold_px must be > 0, got " + std::to_string(threshold_px));
  }
}

bool essential_from_bearings(const Eigen::Vector3f* b0, const Eigen::Vector3f* b1, const int* idx, int m,
                             Eigen::Matrix3d* E_1_0) {
  if (m < 8) return false;
  Eigen::Matrix<double, 9, 9> AtA = Eigen::Matrix<double, 9, 9>::Zero();
  for (int k = 0; k < m; ++k) {
    const Eigen::Vector3d x0 = b0[idx[k]].cast<double>();
    const Eigen::Vector3d x1 = b1[idx[k]].cast<double>();
    Eigen::Matrix<double, 9, 1> a;
    // x1^T E x0 = sum_ij x1_i E_ij x0_j, E stored row-major in a.
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 3; ++j) a(3 * i + j) = x1(i) * x0(j);
    AtA.noalias() += a * a.transpose();
  }
  Eigen::SelfAdjointEigenSolver<Eigen::Matrix<double, 9, 9>> eig(AtA);
  if (eig.info() != Eigen::Success) return false;
  const Eigen::Matrix<double, 9, 1> e = eig.eigenvectors().col(0);  // smallest eigenvalue first
  Eigen::Matrix3d E;
  E << e(0), e(1), e(2), e(3), e(4), e(5), e(6), e(7), e(8);
  Eigen::JacobiSVD<Eigen::Matrix3d> svd(E, Eigen::ComputeFullU | Eigen::ComputeFullV);
  *E_1_0 = svd.matrixU() * Eigen::Vector3d(1.0, 1.0, 0.0).asDiagonal() * svd.matrixV().transpose();
  return E_1_0->allFinite();
}

double sampson_distance(const Eigen::Matrix3d& E, const Eigen::Vector3f& b0, const Eigen::Vector3f& b1) {
  const Eigen::Vector3d x0 = b0.cast<double>() / static_cast<double>(b0.z());
  const Eigen::Vector3d x1 = b1.cast<double>() / static_cast<double>(b1.z());
  const Eigen::Vector3d Ex0 = E * x0;
  const Eigen::Vector3d Etx1 = E.transpose() * x1;
  const double r = x1.dot(Ex0);
  const double den = Ex0(0) * Ex0(0) + Ex0(1) * Ex0(1) + Etx1(0) * Etx1(0) + Etx1(1) * Etx1(1);
  if (!(den > 1e-30)) return std::abs(r) > 1e-12 ? 1e9 : 0.0;
  return std::abs(r) / std::sqrt(den);
}

Status ransac_essential(const Eigen::Vector3f* b0, const Eigen::Vector3f* b1, int n, float focal_px,
                        const RansacOptions& options, Xorshift32* rng, std::uint8_t* inlier, int* n_inliers,
                        Eigen::Matrix3d* E_out) {
  for (int i = 0; i < n; ++i) inlier[i] = 1;
  *n_inliers = n;
  if (n > static_cast<int>(capacity::kMaxFeaturesPerCamera)) return Status::kInvalidInput;
  if (n < 8) return Status::kNotEnoughData;
  const double thr = static_cast<double>(options.threshold_px) / static_cast<double>(focal_px);
  auto count_inliers = [&](const Eigen::Matrix3d& E, double* cost) {
    int c = 0;
    double s = 0.0;
    for (int i = 0; i < n; ++i) {
      const double d = sampson_distance(E, b0[i], b1[i]);
      if (d < thr) {
        ++c;
        s += d;
      }
    }
    *cost = s;
    return c;
  };
  Eigen::Matrix3d best_E = Eigen::Matrix3d::Zero();
  int best = -1;
  double best_cost = 0.0;
  int sample[8];
  for (int it = 0; it < options.iterations; ++it) {
    for (int k = 0; k < 8; ++k) {
      bool unique = false;
      while (!unique) {
        sample[k] = rng->below(n);
        unique = true;
        for (int j = 0; j < k; ++j) unique = unique && sample[j] != sample[k];
      }
    }
    Eigen::Matrix3d E;
    if (!essential_from_bearings(b0, b1, sample, 8, &E)) continue;
    double cost = 0.0;
    const int c = count_inliers(E, &cost);
    if (c > best || (c == best && cost < best_cost)) {
      best = c;
      best_cost = cost;
      best_E = E;
    }
  }
  if (best < 8) return Status::kNotConverged;  // keep everything: no model explains 8 matches
  // Refit once on the inliers of the best hypothesis; keep it only if it explains more.
  int idx_storage[capacity::kMaxFeaturesPerCamera];
  int m = 0;
  for (int i = 0; i < n; ++i) {
    if (sampson_distance(best_E, b0[i], b1[i]) < thr) idx_storage[m++] = i;
  }
  Eigen::Matrix3d refit;
  if (essential_from_bearings(b0, b1, idx_storage, m, &refit)) {
    double cost = 0.0;
    const int c = count_inliers(refit, &cost);
    if (c >= best) best_E = refit;
  }
  int c = 0;
  for (int i = 0; i < n; ++i) {
    inlier[i] = sampson_distance(best_E, b0[i], b1[i]) < thr ? 1 : 0;
    c += inlier[i];
  }
  *n_inliers = c;
  if (E_out != nullptr) *E_out = best_E;
  return Status::kOk;
}

}  // namespace ums
