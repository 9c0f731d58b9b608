#pragma once
// Photo textures: materials for the photo style cut from the real grey images of an EuRoC
// dataset (cam0 and cam1 of e.g. V1_01_easy_micro), so that the estimator's front end sees the
// gradient statistics of a real room instead of procedural value noise.
//
// A material is a mosaic on a toroidal (repeating) texture. One patch per cell of a grid of
// grid_px texels, its centre jittered by up to grid_px / 4, cut (288-320 px square) at a random
// position of a random frame of either camera, with a random flip / 90-degree rotation, a random
// contrast and a random brightness. Each texel shows the patch with the nearest centre (Voronoi
// cells: irregular polygons, not a grid), cross-faded with the patches whose centres are within
// blend_px of the nearest, and the detail is blended variance-preservingly:
//   value = sum w_i (128 + b_i) / sum w_i  +  sum w_i c_i (p_i - mean_i) / sqrt(sum w_i^2),
// so the seams neither form edges (no strong corners along cell boundaries) nor wash the
// contrast out; away from the seams a texel is one real image's pixel, so the gradient
// statistics are those of the real images. Cell size matters for that: the seams join unrelated
// content, and at 64-texel cells the median local contrast was 1.5x the source images', at
// 128-texel cells (0.7-1.3 m of wall) 1.15x.
// Texel density: 1 source pixel per texel at texels_per_m (default 128: 7.8 mm per texel, a
// real image pixel at 3.6 m with EuRoC's 458 px focal length).

#include <cstdint>
#include <string>
#include <vector>

#include "hal/sim/renderer.hpp"

namespace ums::sim {

struct PhotoFrame {
  int width = 0, height = 0;          // px
  std::vector<std::uint8_t> pixels;   // rows packed
};

struct PhotoSource {
  std::vector<PhotoFrame> frames;     // cam0 frames, then cam1 frames
  int cam0_frames = 0;
};

// Reads every PNG of dataset_dir/mav0/cam0/data and cam1/data (name order) with hal/replay's
// PNG reader. Throws std::runtime_error naming the folder when a camera has no image or a PNG
// cannot be read.
PhotoSource load_photo_source(const std::string& dataset_dir);

struct PhotoMaterialOptions {
  int size = 1024;                 // texels per side (power of two, >= 2 grid_px, >= patch_max_px)
  float texels_per_m = 128.0f;     // texel/m on the surface
  int grid_px = 128;               // texels between patch centres (Voronoi cells ~ this wide)
  int blend_px = 24;               // cross-fade band at the cell boundaries, texels (<= grid_px / 4)
  int patch_min_px = 288;          // patch side range, texels (= source px); must cover a cell
  int patch_max_px = 320;          // and its band (validate())
  double contrast_min = 0.8;       // per-patch detail gain range, unitless
  double contrast_max = 1.25;
  double brightness_dn = 15.0;     // per-patch brightness offset in +-this, DN
  bool feather = true;             // false: hard cell boundaries (the seam metric's control in tests)
  bool validate(std::string* error) const;
};

struct MosaicPatch {
  int cx = 0, cy = 0;   // texel of the patch centre (the Voronoi site)
  int x0 = 0, y0 = 0;   // texel of the patch's top-left corner (wraps around the texture)
  int size = 0;         // texels per side
};

// Throws std::runtime_error on invalid options or an empty source. layout (optional) receives
// the patches in cell order (row-major; tests: seam statistics).
Texture make_photo_material(const PhotoSource& source, std::uint32_t seed, const PhotoMaterialOptions& options,
                            std::vector<MosaicPatch>* layout = nullptr);

}  // namespace ums::sim
