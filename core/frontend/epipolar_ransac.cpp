#include "core/frontend/epipolar_ransac.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

#include <Eigen/Eigenvalues>
#include <Eigen/SVD>

#include "core/common/capacity.hpp"

namespace ums {

namespace {
constexpr int kRefitRounds = 4;  // least-squares refits of the best model on its inliers
}  // namespace

void RansacOptions::validate() const {
  if (iterations < 1 || iterations > 10000) {
    throw std::invalid_argument("RansacOptions.iterations must be in 1..10000, got " + std::to_string(iterations));
  }
  if (!(confidence > 0.0f && confidence < 1.0f)) {
    throw std::invalid_argument("RansacOptions.confidence must be in (0, 1), got " + std::to_string(confidence));
  }
  if (!(threshold_px > 0.0f)) {
    throw std::invalid_argument("RansacOptions.threshold_px must be > 0, got " + std::to_string(threshold_px));
  }
}

bool essential_from_bearings(const Eigen::Vector3f* b0, const Eigen::Vector3f* b1, const int* idx, int m,
                             Eigen::Matrix3d* E_1_0) {
  if (m < 8) return false;
  // Hartley normalisation in the z = 1 planes: centroid to the origin, mean distance sqrt(2).
  Eigen::Vector2d c0 = Eigen::Vector2d::Zero(), c1 = Eigen::Vector2d::Zero();
  for (int k = 0; k < m; ++k) {
    c0 += (b0[idx[k]].head<2>() / b0[idx[k]].z()).cast<double>();
    c1 += (b1[idx[k]].head<2>() / b1[idx[k]].z()).cast<double>();
  }
  c0 /= m;
  c1 /= m;
  double s0 = 0.0, s1 = 0.0;
  for (int k = 0; k < m; ++k) {
    s0 += ((b0[idx[k]].head<2>() / b0[idx[k]].z()).cast<double>() - c0).norm();
    s1 += ((b1[idx[k]].head<2>() / b1[idx[k]].z()).cast<double>() - c1).norm();
  }
  if (!(s0 > 1e-12) || !(s1 > 1e-12)) return false;
  s0 = std::sqrt(2.0) * m / s0;
  s1 = std::sqrt(2.0) * m / s1;
  Eigen::Matrix<double, 9, 9> AtA = Eigen::Matrix<double, 9, 9>::Zero();
  for (int k = 0; k < m; ++k) {
    const Eigen::Vector2d p0 = ((b0[idx[k]].head<2>() / b0[idx[k]].z()).cast<double>() - c0) * s0;
    const Eigen::Vector2d p1 = ((b1[idx[k]].head<2>() / b1[idx[k]].z()).cast<double>() - c1) * s1;
    const Eigen::Vector3d x0(p0.x(), p0.y(), 1.0), x1(p1.x(), p1.y(), 1.0);
    Eigen::Matrix<double, 9, 1> a;
    // x1^T F x0 = sum_ij x1_i F_ij x0_j, F stored row-major in a.
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 3; ++j) a(3 * i + j) = x1(i) * x0(j);
    AtA.noalias() += a * a.transpose();
  }
  Eigen::SelfAdjointEigenSolver<Eigen::Matrix<double, 9, 9>> eig(AtA);
  if (eig.info() != Eigen::Success) return false;
  const Eigen::Matrix<double, 9, 1> e = eig.eigenvectors().col(0);  // smallest eigenvalue first
  Eigen::Matrix3d Fn;
  Fn << e(0), e(1), e(2), e(3), e(4), e(5), e(6), e(7), e(8);
  Eigen::Matrix3d T0, T1;
  T0 << s0, 0.0, -s0 * c0.x(), 0.0, s0, -s0 * c0.y(), 0.0, 0.0, 1.0;
  T1 << s1, 0.0, -s1 * c1.x(), 0.0, s1, -s1 * c1.y(), 0.0, 0.0, 1.0;
  const Eigen::Matrix3d E = T1.transpose() * Fn * T0;
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
  int idx_storage[capacity::kMaxFeaturesPerCamera];
  int needed = options.iterations;
  for (int it = 0; it < needed; ++it) {
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
      // Local optimisation (LO-RANSAC): a minimal 8-point model is noise-sensitive, so each new
      // best is refitted on its inliers while the inlier count grows (bounded rounds).
      for (int round = 0; round < kRefitRounds && best >= 8; ++round) {
        int m = 0;
        for (int i = 0; i < n; ++i) {
          if (sampson_distance(best_E, b0[i], b1[i]) < thr) idx_storage[m++] = i;
        }
        Eigen::Matrix3d refit;
        if (!essential_from_bearings(b0, b1, idx_storage, m, &refit)) break;
        double rcost = 0.0;
        const int rc = count_inliers(refit, &rcost);
        if (rc < best || (rc == best && rcost >= best_cost)) break;
        best = rc;
        best_cost = rcost;
        best_E = refit;
      }
      // Adaptive bound (still capped by options.iterations): enough samples for an all-inlier
      // draw with probability options.confidence at the current inlier ratio.
      const double w8 = std::pow(static_cast<double>(best) / n, 8.0);
      if (w8 > 1.0 - 1e-12) {
        needed = std::min(needed, it + 1);
      } else if (w8 > 1e-9) {
        const double k = std::log(1.0 - static_cast<double>(options.confidence)) / std::log(1.0 - w8);
        if (k < static_cast<double>(needed)) needed = std::max(it + 1, static_cast<int>(std::ceil(k)));
      }
    }
  }
  if (best < 8) return Status::kNotConverged;  // keep everything: no model explains 8 matches
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
