#pragma once
// Outlier rejection on the epipolar constraint between two views of one camera (consecutive
// frames): x1^T E x0 = 0 with E = [t]x R on bearing vectors (any camera model, no fundamental
// matrix of distorted pixels). Hypotheses come from the normalised linear 8-point solution
// (Hartley normalisation of the z = 1 points, smallest eigenvector of the 9x9 normal matrix,
// projected onto the essential manifold: singular values (1, 1, 0)); a fixed upper bound of
// iterations (adaptive below it) with a seeded generator makes the result repeatable on every platform; each new
// best model is refitted on its inliers (LO-RANSAC, bounded rounds). Points are scored by the
// Sampson distance in the z = 1 plane, converted to pixels with the camera's focal length.
// Pure rotation or no motion (E -> skew-symmetric family) keeps every consistent match, which is
// what a still camera needs.

#include <cstdint>

#include <Eigen/Core>

#include "core/common/status.hpp"

namespace ums {

struct RansacOptions {
  int iterations = 200;         // hypotheses, upper bound (bounded time)
  float confidence = 0.99f;     // stop earlier once an all-inlier draw is this likely
  float threshold_px = 1.0f;    // px, Sampson distance (VINS-Fusion F_THRESHOLD = 1 px)
  std::uint32_t seed = 0x2545F491u;  // generator seed; the front end reseeds per frame

  void validate() const;  // throws std::invalid_argument naming the field and value
};

// Small, portable generator (xorshift32) so the sampled subsets are identical on x86 and ARM.
struct Xorshift32 {
  std::uint32_t state = 0x2545F491u;
  std::uint32_t next() {
    std::uint32_t x = state;
    x ^= x << 13;
    x ^= x >> 17;
    x ^= x << 5;
    state = x;
    return x;
  }
  // Uniform in [0, n) (n small; the modulo bias is negligible here).
  int below(int n) { return static_cast<int>(next() % static_cast<std::uint32_t>(n)); }
};

// b0[i] <-> b1[i]: unit bearings of match i in view 0 and view 1 (z > 0). Writes inlier[i] (1/0)
// and *n_inliers. With fewer than 8 matches every match is kept and kNotEnoughData returned.
// When a model is found, *E_1_0 (optional) receives it (x1^T E x0 = 0).
Status ransac_essential(const Eigen::Vector3f* b0, const Eigen::Vector3f* b1, int n, float focal_px,
                        const RansacOptions& options, Xorshift32* rng, std::uint8_t* inlier, int* n_inliers,
                        Eigen::Matrix3d* E_1_0 = nullptr);

// Normalised linear 8-point (or more) essential matrix on the given matches (indices idx[0..m)). False when
// the normal matrix is degenerate.
bool essential_from_bearings(const Eigen::Vector3f* b0, const Eigen::Vector3f* b1, const int* idx, int m,
                             Eigen::Matrix3d* E_1_0);

// Sampson distance of a match to E, in the z = 1 plane (multiply by a focal length for px).
double sampson_distance(const Eigen::Matrix3d& E_1_0, const Eigen::Vector3f& b0, const Eigen::Vector3f& b1);

}  // namespace ums
