#pragma once
// Pyramidal Lucas-Kanade point tracking (Bouguet's coarse-to-fine scheme) on our own pyramids.
// Patches are sampled bilinearly in fixed point, as in OpenCV's pyramidal LK: weights in 1/128
// (the position quantized to 1/256 px, under the 0.01 px at which tracking stops), integer sums
// of pixel x weight, so every machine gives the same samples. The window sums (structure tensor,
// residual sums) are exact integer sums over 16-bit samples and differences, 8 per NEON / SSE2
// step, rounded once to float; the Gauss-Newton step is float math.
// The residual is taken between mean-removed windows (an intensity offset between frames or
// between the left and right cameras does not bias it). One call tracks one point; the caller
// runs the forward-backward check by tracking the result back. Template gradients are central
// differences of a patch one pixel larger than the window, so nothing is precomputed per frame
// and no memory is needed beyond a few stack patches.

#include <Eigen/Core>

#include "core/common/capacity.hpp"
#include "core/common/image_view.hpp"
#include "core/common/status.hpp"
#include "core/frontend/image_pyramid.hpp"
#include "core/frontend/klt_template_cache.hpp"

namespace ums {

struct KltOptions {
  int window_px = 15;             // px, odd side of the square window (VINS-Fusion uses 21; on EuRoC
                                  // 15 keeps the 3D count and epipolar RMS at 0.6x the time)
  int max_iterations = 30;        // per pyramid level
  float epsilon_px = 0.01f;       // px, stop when the update is smaller (level 0)
  float coarse_epsilon_px = 0.05f;  // px of the level, the same on the coarser levels: level 0
                                    // refines their result anyway, it only needs its basin
  float min_eigen = 1.0f;         // (grey/px)^2, min eigenvalue of the mean structure tensor
  float max_mean_abs_error = 25.0f;  // grey levels, mean |I - J - offset| over the window after tracking
  // Levels from this one up iterate on every other pixel of the window in both directions
  // (window_px / 2 + 1 samples a side, a quarter of the work per iteration). A level whose
  // template a cache keeps samples the whole template (the cache serves both), tests its texture
  // and cuts the sparse one from it; a level without one samples and tests the sparse grid alone
  // (away from the image edges). A level whose sparse template is untextured stays dense.
  // capacity::kMaxPyramidLevels (default): none.
  int sparse_from_level = capacity::kMaxPyramidLevels;

  static constexpr int kMaxWindowPx = 31;  // px, bound of the stack patches
  // Throws std::invalid_argument naming the field and its value.
  void validate() const;
};

// Tracks p_prev (level-0 px in prev) into curr using the top `levels` levels of both pyramids
// (levels <= both pyramids' level count). *p_curr holds the initial guess on entry (level-0 px;
// pass p_prev when there is none) and the tracked position on success. Returns kOk, or
// kNotConverged when the window is untextured, the point left the image or the final residual
// is too large (then *p_curr is unspecified).
// With a cache (built with klt_template_units(options.window_px) units per level), the
// templates of p_prev in prev come from its slot `slot` when it holds them and go there when it
// does not: the result is the same bits either way. Only sparse levels (sparse_from_level) differ
// between a cached and an uncached template: the cached one's texture test is the whole window's,
// the uncached one's the sparse grid's, so a window textured on one and not the other is tracked
// by one call and refused by the other (same samples, same result otherwise).
Status klt_track(const ImagePyramid& prev, const ImagePyramid& curr, int levels, const KltOptions& options,
                 const Eigen::Vector2f& p_prev, Eigen::Vector2f* p_curr, KltTemplateCache* cache = nullptr,
                 int slot = -1);

// 16-bit units of one level's template in a KltTemplateCache for windows of window_px.
int klt_template_units(int window_px);

// Samples an n x n patch whose top-left sample sits at (x, y) (sub-pixel, level px) with bilinear
// interpolation in fixed point (grey levels out): with X = round(128 ax), Y = round(128 ay) for
// the fractions ax, ay of x, y, the weights are w11 = round(X Y / 128), w01 = X - w11,
// w10 = Y - w11, w00 = 128 - X - Y + w11, and a sample is (sum of w p) / 128, exact. Samples
// outside the image use the nearest border pixel. out has n*n floats; n is
// 1..KltOptions::kMaxWindowPx + 2 (std::invalid_argument otherwise).
void sample_patch_bilinear(const ImageView& image, float x, float y, int n, float* out);

// The n x n samples of sample_patch_bilinear's 2n - 1 patch at (x, y) that lie on its even rows
// and columns (two pixels apart), the same values bit for bit: the sparse window. n is
// 1..KltOptions::kMaxWindowPx / 2 + 1 (std::invalid_argument otherwise).
void sample_sparse_bilinear(const ImageView& image, float x, float y, int n, float* out);

}  // namespace ums
