#pragma once
// Shi-Tomasi corners (the minimum eigenvalue of the 3x3-summed structure tensor of Sobel
// gradients), 3x3 non-maximum suppression, a threshold relative to the strongest response in the
// free area (as OpenCV's goodFeaturesToTrack with a mask) with an absolute floor, strongest-first selection under a minimum-distance mask, and sub-pixel
// refinement of each accepted corner (the paper's "sub-pixel plane", Sec. III-A.1). The
// refinement solves for the point q where every gradient g_i in a window is orthogonal to
// (p_i - q): sum_i g_i g_i^T (p_i - q) = 0, iterated on bilinearly sampled gradients.
//
// All buffers (response image, mask, candidate heap) are allocated at construction.

#include <cstdint>
#include <vector>

#include <Eigen/Core>

#include "core/common/capacity.hpp"
#include "core/common/image_view.hpp"

namespace ums {

struct DetectorOptions {
  float quality_level = 0.003f;   // fraction of the strongest response (OpenCV/VINS use 0.01; with
                                  // glare in view, e.g. EuRoC V1 windows, 0.01 leaves 100 corners)
  float min_response = 8.0f;      // (grey/px)^2, absolute floor: keeps sensor noise out of flat areas
  float min_distance_px = 25.0f;  // px, between any two features (new or existing)
  int border_px = 10;             // px, no corner closer to the image edge
  int subpix_half_window = 4;     // px, refinement window is (2h+1)^2
  int subpix_max_iterations = 10;
  float subpix_epsilon_px = 0.01f;  // px, stop when the update is smaller

  void validate() const;  // throws std::invalid_argument naming the field and value
};

class CornerDetector {
 public:
  static constexpr int kMaxSubpixHalfWindow = 8;

  CornerDetector(int width, int height);  // start-up: allocates the buffers

  // Mask: features may only be placed where no disk was blocked since the last clear.
  void clear_mask();
  void block_disk(const Eigen::Vector2f& center_px, float radius_px);
  bool is_free(const Eigen::Vector2f& p_px) const;

  // Detects up to max_new corners in free areas of image, writes their refined positions (px)
  // strongest first and blocks a min_distance disk around each. Returns the count. The image
  // size must be the constructed one (otherwise returns 0).
  int detect(const ImageView& image, int max_new, const DetectorOptions& options, Eigen::Vector2f* out_px);

  // The Shi-Tomasi response of the last detect() at integer pixel (x, y), (grey/px)^2: 0 within
  // 2 px of the image edge, NaN where that detect() did not compute it. It is computed only in
  // the column groups (kGroupPx wide) holding a free pixel inside the border in the row or the
  // rows above and below, and one pixel to either side: where a corner may be placed and its 3x3
  // neighbours.
  float response(int x, int y) const;

  static constexpr int kGroupPx = 8;
  static constexpr int kGroupWords = (capacity::kMaxImageWidth / kGroupPx + 63) / 64;

  // Iterative sub-pixel refinement of *p (px) in place. False when it diverged (moved farther
  // than the window half size) or the window is untextured; *p is then left unchanged.
  static bool refine_subpixel(const ImageView& image, const DetectorOptions& options, Eigen::Vector2f* p);

 private:
  struct Candidate {
    float score;
    int x, y;
  };
  // A function object, not a function pointer: the heap operations inline the comparison.
  struct ScoresGreater {
    bool operator()(const Candidate& l, const Candidate& r) const { return l.score > r.score; }
  };
  // The selection order as a strict total order: l comes after r (lower score, or the same score
  // later in scan order).
  struct RanksBelow {
    bool operator()(const Candidate& l, const Candidate& r) const {
      if (l.score != r.score) return l.score < r.score;
      return l.y != r.y ? l.y > r.y : l.x > r.x;
    }
  };
  void offer(const Candidate& c);  // kept when among the strongest kMaxCornerCandidates
  void mark_needed_groups(int b);  // need_ from the mask
  // Fills response_ in the groups of need_ and returns its maximum over free pixels at least b
  // from the image edge.
  float compute_response(const ImageView& image, int b);
  // Offers row y's free 3x3 maxima at or above thresh, at least b from the side edges.
  void offer_row_maxima(int y, int b, float thresh);

  int width_ = 0, height_ = 0;
  std::vector<float> response_;
  std::vector<float> rows_;  // 3 rolling rows of Ixx, Ixy, Iyy products (9 * width), then their
                             // vertical 3-row sums (3 * width)
  std::vector<std::uint8_t> mask_;
  std::vector<std::uint64_t> need_;     // per row, kGroupWords of column-group bits: response computed
  std::vector<std::uint64_t> scratch_;  // per row, the groups holding a free pixel inside the border
                                        // (mark_needed_groups; the candidate scan visits only them)
  std::vector<Candidate> heap_;  // capacity::kMaxCornerCandidates: appended, a bounded min-heap once full (offer)
};

}  // namespace ums
