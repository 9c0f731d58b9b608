#include "core/loop/loop_verifier.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

#include <Eigen/Eigenvalues>

#include <Eigen/Cholesky>
#include <Eigen/Geometry>

#include "core/estimator/geometry.hpp"
#include "core/math/so3.hpp"

namespace ums::loop {

namespace {

constexpr std::size_t kMaxF = capacity::kMaxLoopFeaturesPerKeyframe;

// xorshift32: the same samples on every build.
std::uint32_t next_random(std::uint32_t* s) {
  std::uint32_t x = *s;
  x ^= x << 13;
  x ^= x >> 17;
  x ^= x << 5;
  return *s = x;
}

double angle_between(const Eigen::Vector3d& a_unit, const Eigen::Vector3d& p) {
  const double n = p.norm();
  if (!(n > 1e-9) || p.z() <= 0.0) return 1e9;  // behind the camera
  return std::acos(std::min(1.0, a_unit.dot(p / n)));
}

}  // namespace

LoopVerifier::LoopVerifier(const LoopVerifierOptions& options, const Eigen::Isometry3d& T_b_c0)
    : options_(options),
      T_b_c0_(T_b_c0),
      T_c0_b_(T_b_c0.inverse()),
      qi_(new std::uint16_t[kMaxF]),
      ci_(new std::uint16_t[kMaxF]),
      best_of_c_(new std::int16_t[kMaxF]),
      mask_(new std::uint8_t[kMaxF]),
      best_mask_(new std::uint8_t[kMaxF]) {}

int LoopVerifier::match(const KeyframeRecord& q, const KeyframeRecord& c) {
  // Each candidate feature's nearest query feature, then keep the query features whose nearest
  // candidate feature points back at them (mutual), under the Hamming bound.
  const int nq = static_cast<int>(q.features.size());
  const int nc = static_cast<int>(c.features.size());
  for (int j = 0; j < nc; ++j) {
    int best = 257, arg = -1;
    for (int i = 0; i < nq; ++i) {
      const int d = hamming(q.features[i].descriptor, c.features[j].descriptor);
      if (d < best) best = d, arg = i;
    }
    best_of_c_[j] = static_cast<std::int16_t>(best <= options_.max_hamming ? arg : -1);
  }
  n_ = 0;
  for (int i = 0; i < nq; ++i) {
    int best = 257, arg = -1;
    for (int j = 0; j < nc; ++j) {
      const int d = hamming(q.features[i].descriptor, c.features[j].descriptor);
      if (d < best) best = d, arg = j;
    }
    if (arg < 0 || best > options_.max_hamming || best_of_c_[arg] != i) continue;
    qi_[n_] = static_cast<std::uint16_t>(i);
    ci_[n_] = static_cast<std::uint16_t>(arg);
    ++n_;
  }
  return n_;
}

int LoopVerifier::count_inliers(const KeyframeRecord& q, const KeyframeRecord& c,
                                const Eigen::Isometry3d& T_c_q, std::uint8_t* mask, double bound_rad) const {
  // A match is an inlier when each keyframe's point reprojects onto the other's observation.
  const Eigen::Isometry3d T_c0c_bq = T_c0_b_ * T_c_q;
  const Eigen::Isometry3d T_c0q_bc = T_c0_b_ * T_c_q.inverse();
  int n_in = 0;
  for (int k = 0; k < n_; ++k) {
    const LoopFeature& fq = q.features[qi_[k]];
    const LoopFeature& fc = c.features[ci_[k]];
    const double e_c = angle_between(fc.bearing_c0.cast<double>(), T_c0c_bq * fq.p_b.cast<double>());
    const double e_q = angle_between(fq.bearing_c0.cast<double>(), T_c0q_bc * fc.p_b.cast<double>());
    const bool in = e_c < bound_rad && e_q < bound_rad;
    mask[k] = in ? 1 : 0;
    n_in += in ? 1 : 0;
  }
  return n_in;
}

bool LoopVerifier::ransac(const KeyframeRecord& q, const KeyframeRecord& c, Eigen::Isometry3d* T_c_q) {
  std::uint32_t rng = options_.seed;
  int best_inliers = 3;
  for (int it = 0; it < options_.ransac_iterations; ++it) {
    int s[3];
    for (int k = 0; k < 3; ++k) s[k] = static_cast<int>(next_random(&rng) % static_cast<std::uint32_t>(n_));
    if (s[0] == s[1] || s[0] == s[2] || s[1] == s[2]) continue;
    Eigen::Matrix3d src, dst;
    for (int k = 0; k < 3; ++k) {
      src.col(k) = q.features[qi_[s[k]]].p_b.cast<double>();
      dst.col(k) = c.features[ci_[s[k]]].p_b.cast<double>();
    }
    // A degenerate (nearly collinear) sample fixes no rotation about its line.
    if ((src.col(1) - src.col(0)).cross(src.col(2) - src.col(0)).norm() < 1e-3) continue;
    Eigen::Isometry3d T;
    T.matrix() = Eigen::umeyama(src, dst, false);
    const int n_in = count_inliers(q, c, T, mask_.get(), options_.inlier_rad);
    if (n_in > best_inliers) {
      best_inliers = n_in;
      *T_c_q = T;
    }
  }
  return best_inliers > 3;
}

bool LoopVerifier::refine(const KeyframeRecord& q, const KeyframeRecord& c, LoopGeometry* out) {
  PnpMatch m[kMaxF];
  for (int k = 0; k < n_; ++k) {
    m[k].p_w = c.features[ci_[k]].p_b.cast<double>();
    m[k].bearing = q.features[qi_[k]].bearing_c0.cast<double>();
    m[k].cam = 0;
  }
  PnpOptions po;
  po.inlier_rad = options_.inlier_rad;
  po.min_inliers = 4;
  po.seed = options_.seed;
  const Eigen::Isometry3d T_b_c[2] = {T_b_c0_, T_b_c0_};
  Eigen::Isometry3d T = out->T_c_q;
  const PnpResult r = solve_pnp(m, n_, T_b_c, po, &T, best_mask_.get());
  if (!r.ok) return false;
  out->inliers = count_inliers(q, c, T, mask_.get(), options_.inlier_rad);
  refine_both_ways(q, c, &T);
  // Matches that fit only loosely (a wrong corner a few pixels off) still pull a least-squares
  // fit: refine once more on those within a third of the inlier bound.
  const int tight = count_inliers(q, c, T, mask_.get(), options_.inlier_rad / 3.0);
  if (tight >= 8) refine_both_ways(q, c, &T);
  out->T_c_q = T;
  out->inliers = count_inliers(q, c, T, mask_.get(), options_.inlier_rad);
  out->rms_rad = r.rms_rad;
  uncertainty(q, c, out);
  return true;
}

int LoopVerifier::inlier_pairs(std::uint16_t* query_index, std::uint16_t* candidate_index) const {
  int n = 0;
  for (int k = 0; k < n_; ++k) {
    if (!mask_[k]) continue;
    query_index[n] = qi_[k];
    candidate_index[n++] = ci_[k];
  }
  return n;
}

void LoopVerifier::uncertainty(const KeyframeRecord& q, const KeyframeRecord& c, LoopGeometry* out) const {
  Eigen::Matrix<double, 6, 6> H;
  double squared_sum = 0.0;
  int rows = 0;
  both_ways_residual_sum(q, c, out->T_c_q, &H, &squared_sum, &rows);
  const Eigen::LDLT<Eigen::Matrix<double, 6, 6>> ldlt(H);
  if (rows <= 6 || ldlt.info() != Eigen::Success) {
    out->sigma_p_m = out->sigma_rot_rad = std::numeric_limits<double>::infinity();
    return;
  }
  const double variance = squared_sum / static_cast<double>(rows - 6);
  const Eigen::Matrix<double, 6, 6> cov = variance * ldlt.solve(Eigen::Matrix<double, 6, 6>::Identity());
  // Largest axis: the position block is in the query's body frame, a rotation keeps its eigenvalues.
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> rot(cov.topLeftCorner<3, 3>());
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> pos(cov.bottomRightCorner<3, 3>());
  out->sigma_rot_rad = std::sqrt(std::max(0.0, rot.eigenvalues().maxCoeff()));
  out->sigma_p_m = std::sqrt(std::max(0.0, pos.eigenvalues().maxCoeff()));
}

namespace {

// Tangent-plane bearing error (2 rows) of point p seen along unit bearing b: b's orthogonal
// complement basis applied to p / |p|.
Eigen::Vector2d bearing_error(const Eigen::Vector3d& b, const Eigen::Vector3d& p) {
  const Eigen::Vector3d u = b.unitOrthogonal();
  const Eigen::Vector3d v = b.cross(u);
  const Eigen::Vector3d d = p.normalized();
  return Eigen::Vector2d(u.dot(d), v.dot(d));
}

}  // namespace

Eigen::Matrix<double, 6, 1> LoopVerifier::both_ways_residual_sum(const KeyframeRecord& q, const KeyframeRecord& c,
                                                                const Eigen::Isometry3d& T_c_q,
                                                                Eigen::Matrix<double, 6, 6>* H, double* squared_sum,
                                                                int* rows) const {
  // Numeric Jacobians in the tangent of T_c_q (right perturbation [dtheta, dp]): small, off the
  // frame path, and exact enough for a few Gauss-Newton steps.
  H->setZero();
  Eigen::Matrix<double, 6, 1> g = Eigen::Matrix<double, 6, 1>::Zero();
  constexpr double kEps = 1e-6;
  auto residual = [&](const Eigen::Isometry3d& T, const LoopFeature& fq, const LoopFeature& fc) {
    Eigen::Vector4d r;
    r.head<2>() = bearing_error(fc.bearing_c0.cast<double>(), T_c0_b_ * (T * fq.p_b.cast<double>()));
    r.tail<2>() = bearing_error(fq.bearing_c0.cast<double>(), T_c0_b_ * (T.inverse() * fc.p_b.cast<double>()));
    return r;
  };
  for (int k = 0; k < n_; ++k) {
    if (!mask_[k]) continue;
    const LoopFeature& fq = q.features[qi_[k]];
    const LoopFeature& fc = c.features[ci_[k]];
    const Eigen::Vector4d r0 = residual(T_c_q, fq, fc);
    Eigen::Matrix<double, 4, 6> J;
    for (int d = 0; d < 6; ++d) {
      Eigen::Matrix<double, 6, 1> delta = Eigen::Matrix<double, 6, 1>::Zero();
      delta[d] = kEps;
      Eigen::Isometry3d T = T_c_q;
      T.linear() = T_c_q.linear() * so3::exp(delta.head<3>());
      T.translation() += T_c_q.linear() * delta.tail<3>();
      J.col(d) = (residual(T, fq, fc) - r0) / kEps;
    }
    *H += J.transpose() * J;
    g += J.transpose() * r0;
    if (squared_sum != nullptr) *squared_sum += r0.squaredNorm();
    if (rows != nullptr) *rows += 4;
  }
  return g;
}

void LoopVerifier::refine_both_ways(const KeyframeRecord& q, const KeyframeRecord& c, Eigen::Isometry3d* T_c_q) const {
  for (int it = 0; it < 5; ++it) {
    Eigen::Matrix<double, 6, 6> H;
    const Eigen::Matrix<double, 6, 1> g = both_ways_residual_sum(q, c, *T_c_q, &H);
    const Eigen::LDLT<Eigen::Matrix<double, 6, 6>> ldlt(H);
    if (ldlt.info() != Eigen::Success) return;
    const Eigen::Matrix<double, 6, 1> dx = -ldlt.solve(g);
    if (!dx.allFinite()) return;
    T_c_q->linear() = T_c_q->linear() * so3::exp(dx.head<3>());
    T_c_q->translation() += T_c_q->linear() * dx.tail<3>();
    if (dx.norm() < 1e-9) return;
  }
}

bool LoopVerifier::verify(const KeyframeRecord& query, const KeyframeRecord& candidate, LoopGeometry* out) {
  *out = LoopGeometry{};
  out->matches = match(query, candidate);
  if (out->matches < options_.min_matches) return false;
  if (!ransac(query, candidate, &out->T_c_q)) return false;
  out->inliers = count_inliers(query, candidate, out->T_c_q, mask_.get(), options_.inlier_rad);
  return refine(query, candidate, out);
}

}  // namespace ums::loop
