#include "core/estimator/geometry.hpp"

#include <cmath>

#include <Eigen/Cholesky>

#include "core/math/so3.hpp"

namespace ums {

TriangulationResult triangulate(const Ray* rays, int n, double min_angle_rad) {
  TriangulationResult out;
  if (n < 2) return out;
  Eigen::Matrix3d A = Eigen::Matrix3d::Zero();
  Eigen::Vector3d rhs = Eigen::Vector3d::Zero();
  double min_cos = 1.0;
  for (int k = 0; k < n; ++k) {
    const Eigen::Vector3d& d = rays[k].direction;
    const Eigen::Matrix3d P = Eigen::Matrix3d::Identity() - d * d.transpose();
    A += P;
    rhs += P * rays[k].origin;
    if (k > 0) min_cos = std::min(min_cos, d.dot(rays[0].direction));
  }
  out.max_angle_rad = std::acos(std::max(-1.0, std::min(1.0, min_cos)));
  if (out.max_angle_rad < min_angle_rad) return out;
  const Eigen::LDLT<Eigen::Matrix3d> ldlt(A);
  if (ldlt.info() != Eigen::Success) return out;
  out.p_w = ldlt.solve(rhs);
  if (!out.p_w.allFinite()) return out;
  for (int k = 0; k < n; ++k)
    if ((out.p_w - rays[k].origin).dot(rays[k].direction) <= 0.0) return out;
  out.ok = true;
  return out;
}

namespace {

Eigen::Matrix<double, 3, 2> tangent_basis(const Eigen::Vector3d& b) {
  Eigen::Vector3d a = std::abs(b.x()) > 0.6 ? Eigen::Vector3d::UnitY() : Eigen::Vector3d::UnitX();
  const Eigen::Vector3d t1 = (a - b * b.dot(a)).normalized();
  Eigen::Matrix<double, 3, 2> B;
  B.col(0) = t1;
  B.col(1) = b.cross(t1);
  return B;
}

// Angular error (rad) of a match; T_c_w[cam] = (T_w_b T_b_c[cam])^-1. Negative when the point is
// behind the camera.
double match_error(const PnpMatch& m, const Eigen::Isometry3d* T_c_w) {
  const Eigen::Vector3d P_c = T_c_w[m.cam] * m.p_w;
  const double n = P_c.norm();
  if (!(n > 1e-9) || P_c.dot(m.bearing) <= 0.0) return -1.0;
  return (P_c / n - m.bearing).norm();
}

// Gauss-Newton on the tangent-plane bearing errors of the listed matches.
bool gauss_newton(const PnpMatch* matches, const int* idx, int n, const Eigen::Isometry3d* T_b_c,
                  int iterations, Eigen::Isometry3d* T_w_b) {
  Eigen::Vector3d p = T_w_b->translation();
  Eigen::Matrix3d R = T_w_b->linear();
  for (int it = 0; it < iterations; ++it) {
    Eigen::Matrix<double, 6, 6> H = Eigen::Matrix<double, 6, 6>::Zero();
    Eigen::Matrix<double, 6, 1> g = Eigen::Matrix<double, 6, 1>::Zero();
    int used = 0;
    for (int k = 0; k < n; ++k) {
      const PnpMatch& m = matches[idx[k]];
      const Eigen::Matrix3d R_b_c = T_b_c[m.cam].linear();
      const Eigen::Vector3d P_b = R.transpose() * (m.p_w - p);
      const Eigen::Vector3d P_c = R_b_c.transpose() * (P_b - T_b_c[m.cam].translation());
      const double nrm = P_c.norm();
      if (!(nrm > 1e-9) || P_c.dot(m.bearing) <= 0.0) continue;
      const Eigen::Vector3d u = P_c / nrm;
      const Eigen::Matrix<double, 3, 2> B = tangent_basis(m.bearing);
      const Eigen::Vector2d r = B.transpose() * (u - m.bearing);
      const Eigen::Matrix<double, 2, 3> D = B.transpose() * (Eigen::Matrix3d::Identity() - u * u.transpose()) / nrm;
      Eigen::Matrix<double, 3, 6> dP;
      dP.leftCols<3>() = -R_b_c.transpose() * R.transpose();
      dP.rightCols<3>() = R_b_c.transpose() * so3::hat(P_b);
      const Eigen::Matrix<double, 2, 6> J = D * dP;
      H += J.transpose() * J;
      g += J.transpose() * r;
      ++used;
    }
    if (used < 3) return false;
    H.diagonal().array() += 1e-9;
    const Eigen::Matrix<double, 6, 1> dx = -H.ldlt().solve(g);
    if (!dx.allFinite()) return false;
    p += dx.head<3>();
    R = R * so3::exp(dx.tail<3>());
    if (dx.norm() < 1e-10) break;
  }
  T_w_b->translation() = p;
  T_w_b->linear() = Eigen::Quaterniond(R).normalized().toRotationMatrix();
  return true;
}

std::uint32_t next_random(std::uint32_t* s) {
  std::uint32_t x = *s;
  x ^= x << 13;
  x ^= x >> 17;
  x ^= x << 5;
  *s = x;
  return x;
}

}  // namespace

namespace {

constexpr int kMaxPnpMatches = 1024;

// Matches within inlier_rad of their prediction at pose T (indices into idx when given).
int count_inliers(const PnpMatch* matches, int n, const Eigen::Isometry3d* T_b_c, const Eigen::Isometry3d& T,
                  double inlier_rad, int* idx) {
  int m = 0;
  const Eigen::Isometry3d T_c_w[2] = {(T * T_b_c[0]).inverse(), (T * T_b_c[1]).inverse()};
  for (int k = 0; k < n; ++k) {
    const double e = match_error(matches[k], T_c_w);
    if (e >= 0.0 && e < inlier_rad) {
      if (idx != nullptr) idx[m] = k;
      ++m;
    }
  }
  return m;
}

// RANSAC: the prior itself is the first hypothesis (a good IMU prediction needs no sampling),
// then minimal samples fitted by Gauss-Newton; the pose with the most inliers (the first found
// of them), or -1.
int ransac_pnp(const PnpMatch* matches, int n, const Eigen::Isometry3d* T_b_c, const PnpOptions& options,
               const Eigen::Isometry3d& prior, Eigen::Isometry3d* best) {
  int best_inliers = -1;
  std::uint32_t rng = options.seed == 0 ? 1u : options.seed;
  for (int it = 0; it <= options.ransac_iterations; ++it) {
    Eigen::Isometry3d T = prior;
    if (it > 0) {
      int sample[16];
      const int s = std::min(options.sample_size, 16);
      for (int k = 0; k < s; ++k) {
        bool fresh = false;
        while (!fresh) {
          sample[k] = static_cast<int>(next_random(&rng) % static_cast<std::uint32_t>(n));
          fresh = true;
          for (int j = 0; j < k; ++j) fresh = fresh && sample[j] != sample[k];
        }
      }
      if (!gauss_newton(matches, sample, s, T_b_c, options.gn_iterations, &T)) continue;
    }
    const int inliers = count_inliers(matches, n, T_b_c, T, options.inlier_rad, nullptr);
    if (inliers > best_inliers) {
      best_inliers = inliers;
      *best = T;
    }
    // Every match an inlier: no later hypothesis can have more (a good prior usually does).
    if (best_inliers == n) break;
  }
  return best_inliers;
}

}  // namespace

PnpResult solve_pnp(const PnpMatch* matches, int n, const Eigen::Isometry3d* T_b_c,
                    const PnpOptions& options, Eigen::Isometry3d* T_w_b, std::uint8_t* inlier_mask) {
  PnpResult out;
  if (n < options.min_inliers || n < options.sample_size) return out;
  if (n > kMaxPnpMatches) n = kMaxPnpMatches;
  int idx[kMaxPnpMatches];
  Eigen::Isometry3d best = *T_w_b;
  if (ransac_pnp(matches, n, T_b_c, options, *T_w_b, &best) < options.min_inliers) return out;
  // Refine on the inliers, re-select once with the refined pose.
  for (int pass = 0; pass < 2; ++pass) {
    const int m = count_inliers(matches, n, T_b_c, best, options.inlier_rad, idx);
    if (m < options.min_inliers) return out;
    Eigen::Isometry3d T = best;
    if (!gauss_newton(matches, idx, m, T_b_c, options.gn_iterations, &T)) return out;
    best = T;
  }
  double sum_sq = 0.0;
  int inliers = 0;
  const Eigen::Isometry3d T_c_w[2] = {(best * T_b_c[0]).inverse(), (best * T_b_c[1]).inverse()};
  for (int k = 0; k < n; ++k) {
    const double e = match_error(matches[k], T_c_w);
    const bool in = e >= 0.0 && e < options.inlier_rad;
    if (inlier_mask != nullptr) inlier_mask[k] = in ? 1 : 0;
    if (in) {
      ++inliers;
      sum_sq += e * e;
    }
  }
  if (inliers < options.min_inliers) return out;
  out.ok = true;
  out.inliers = inliers;
  out.rms_rad = std::sqrt(sum_sq / inliers);
  *T_w_b = best;
  return out;
}

}  // namespace ums
