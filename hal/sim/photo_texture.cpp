#include "hal/sim/photo_texture.hpp"

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <stdexcept>

#include "core/common/capacity.hpp"
#include "hal/replay/png_io.hpp"

namespace ums::sim {
namespace {

std::uint64_t splitmix(std::uint64_t& s) {
  std::uint64_t z = (s += 0x9E3779B97F4A7C15ULL);
  z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ULL;
  z = (z ^ (z >> 27)) * 0x94D049BB133111EBULL;
  return z ^ (z >> 31);
}

constexpr float kBorderFeatherPx = 8.0f;  // texels over which a patch fades out at its border

double uniform(std::uint64_t& s, double a, double b) {
  return a + (b - a) * static_cast<double>(splitmix(s) >> 11) * (1.0 / 9007199254740992.0);
}

int uniform_int(std::uint64_t& s, int a, int b) {  // [a, b]
  return a + static_cast<int>(splitmix(s) % static_cast<std::uint64_t>(b - a + 1));
}

void load_camera(const std::filesystem::path& dir, PhotoSource* source) {
  std::vector<std::string> names;
  if (std::filesystem::is_directory(dir)) {
    for (const auto& e : std::filesystem::directory_iterator(dir)) {
      if (e.path().extension() == ".png") names.push_back(e.path().string());
    }
  }
  if (names.empty()) throw std::runtime_error(dir.string() + ": no PNG images (need an EuRoC dataset folder)");
  std::sort(names.begin(), names.end());
  std::vector<std::uint8_t> buf(static_cast<std::size_t>(capacity::kMaxImageWidth) * capacity::kMaxImageHeight);
  for (const std::string& name : names) {
    PhotoFrame f;
    std::string err;
    if (!hal::read_png_gray8(name, buf.data(), buf.size(), &f.width, &f.height, &err)) throw std::runtime_error(err);
    f.pixels.assign(buf.begin(), buf.begin() + static_cast<std::ptrdiff_t>(f.width) * f.height);
    source->frames.push_back(std::move(f));
  }
}

// One patch, drawn: where it goes, where it comes from and how it is transformed.
struct PatchDraw {
  MosaicPatch place;
  const PhotoFrame* frame = nullptr;
  int sx = 0, sy = 0;       // source top-left, px
  int orientation = 0;      // bit 0: mirror, bits 1-2: quarter turns
  float contrast = 1.0f;    // detail gain
  float base_dn = 128.0f;   // brightness the patch pulls towards
  float mean_dn = 0.0f;     // mean of its source pixels
};

// Source pixel of patch texel (x, y) under the patch's flip / rotation.
std::uint8_t source_pixel(const PatchDraw& d, int x, int y) {
  const int n = d.place.size - 1;
  if (d.orientation & 1) x = n - x;
  for (int r = 0; r < (d.orientation >> 1); ++r) {
    const int t = x;
    x = n - y;
    y = t;
  }
  return d.frame->pixels[static_cast<std::size_t>(d.sy + y) * static_cast<std::size_t>(d.frame->width) +
                         static_cast<std::size_t>(d.sx + x)];
}

PatchDraw draw_patch(const PhotoSource& src, const PhotoMaterialOptions& o, int ci, int cj, std::uint64_t& rng) {
  PatchDraw d;
  const int jitter = o.grid_px / 4;
  d.place.size = uniform_int(rng, o.patch_min_px, o.patch_max_px);
  d.place.cx = ci * o.grid_px + o.grid_px / 2 + uniform_int(rng, -jitter, jitter);
  d.place.cy = cj * o.grid_px + o.grid_px / 2 + uniform_int(rng, -jitter, jitter);
  d.place.x0 = d.place.cx - d.place.size / 2;
  d.place.y0 = d.place.cy - d.place.size / 2;
  d.frame = &src.frames[static_cast<std::size_t>(uniform_int(rng, 0, static_cast<int>(src.frames.size()) - 1))];
  d.sx = uniform_int(rng, 0, d.frame->width - d.place.size);
  d.sy = uniform_int(rng, 0, d.frame->height - d.place.size);
  d.orientation = uniform_int(rng, 0, 7);
  d.contrast = static_cast<float>(uniform(rng, o.contrast_min, o.contrast_max));
  d.base_dn = static_cast<float>(128.0 + uniform(rng, -o.brightness_dn, o.brightness_dn));
  double sum = 0.0;
  for (int y = 0; y < d.place.size; ++y)
    for (int x = 0; x < d.place.size; ++x) sum += source_pixel(d, x, y);
  d.mean_dn = static_cast<float>(sum / (static_cast<double>(d.place.size) * d.place.size));
  return d;
}

float smoothstep01(float s) {
  s = std::clamp(s, 0.0f, 1.0f);
  return s * s * (3.0f - 2.0f * s);
}

int wrap_delta(int d, int size) {  // into [-size/2, size/2)
  d &= size - 1;
  return d >= size / 2 ? d - size : d;
}

// One texel: the patches whose centres lie within the blend band of the nearest (5x5 cells
// around the texel's own cover every candidate, see validate()), weighted by band position and
// by a feather at the patch border; variance-preserving blend of their detail.
float mosaic_texel(const std::vector<PatchDraw>& patches, const PhotoMaterialOptions& o, int x, int y) {
  const int cells = o.size / o.grid_px;
  const int ci = x / o.grid_px, cj = y / o.grid_px;
  // Fewer than 5 cells per side: every cell once.
  const int lo = cells >= 5 ? -2 : -(cells / 2), hi = cells >= 5 ? 2 : (cells - 1) / 2;
  const PatchDraw* cand[25];
  float dist[25];
  int n = 0;
  float d_min = 1e9f;
  for (int j = lo; j <= hi; ++j)
    for (int i = lo; i <= hi; ++i) {
      const PatchDraw& p = patches[static_cast<std::size_t>(((cj + j + cells) % cells) * cells + (ci + i + cells) % cells)];
      const float dx = static_cast<float>(wrap_delta(x - p.place.cx, o.size));
      const float dy = static_cast<float>(wrap_delta(y - p.place.cy, o.size));
      cand[n] = &p;
      dist[n] = std::sqrt(dx * dx + dy * dy);
      d_min = std::min(d_min, dist[n]);
      ++n;
    }
  float sw = 0.0f, sw2 = 0.0f, sbase = 0.0f, sdetail = 0.0f;
  for (int k = 0; k < n; ++k) {
    const PatchDraw& p = *cand[k];
    float w = o.feather ? smoothstep01((d_min + static_cast<float>(o.blend_px) - dist[k]) / static_cast<float>(o.blend_px))
                        : (dist[k] == d_min ? 1.0f : 0.0f);
    if (w <= 0.0f) continue;
    const int lx = wrap_delta(x - p.place.x0, o.size), ly = wrap_delta(y - p.place.y0, o.size);
    if (lx < 0 || ly < 0 || lx >= p.place.size || ly >= p.place.size) continue;
    const int edge = std::min(std::min(lx, p.place.size - 1 - lx), std::min(ly, p.place.size - 1 - ly));
    if (o.feather) w *= smoothstep01(static_cast<float>(edge) / kBorderFeatherPx);
    sw += w;
    sw2 += w * w;
    sbase += w * p.base_dn;
    sdetail += w * p.contrast * (static_cast<float>(source_pixel(p, lx, ly)) - p.mean_dn);
    if (!o.feather) break;  // hard cut: the nearest patch alone (ties: the first)
  }
  return sbase / sw + sdetail / std::sqrt(sw2);
}

}  // namespace

PhotoSource load_photo_source(const std::string& dataset_dir) {
  PhotoSource source;
  const std::filesystem::path mav0 = std::filesystem::path(dataset_dir) / "mav0";
  load_camera(mav0 / "cam0" / "data", &source);
  source.cam0_frames = static_cast<int>(source.frames.size());
  load_camera(mav0 / "cam1" / "data", &source);
  return source;
}

bool PhotoMaterialOptions::validate(std::string* error) const {
  auto bad = [&](const std::string& m) {
    if (error) *error = "PhotoMaterialOptions: " + m;
    return false;
  };
  if (size < 64 || size > 4096 || (size & (size - 1)) != 0) return bad("size must be a power of two in [64, 4096]");
  if (grid_px < 16 || size % grid_px != 0 || size / grid_px < 2) return bad("grid_px must be >= 16 and divide size at least twice");
  if (patch_max_px > size) return bad("patch_max_px must be <= size");
  // The nearest centre is within sqrt(2) (grid/2 + jitter) of a texel; its patch must reach that
  // far plus the border feather. Blend candidates (within the band of the nearest) lie within
  // the 5x5 cells around the texel's own when blend_px <= grid / 4 (a centre 3 cells away is
  // >= 2.5 grid - jitter = 2.25 grid away, the band ends by sqrt(2) 0.75 grid + grid / 4).
  const double reach = std::sqrt(2.0) * (grid_px / 2 + grid_px / 4) + static_cast<double>(kBorderFeatherPx);
  if (patch_min_px < 2.0 * reach || patch_max_px < patch_min_px) return bad("patch_min_px must be >= 2 (sqrt(2) 3/4 grid_px + 8) and <= patch_max_px");
  if (blend_px < 2 || blend_px > grid_px / 4) return bad("blend_px must be in [2, grid_px / 4]");
  if (!(texels_per_m > 0.0f) || !(contrast_min > 0.0 && contrast_max >= contrast_min) || !(brightness_dn >= 0.0)) {
    return bad("texels_per_m > 0, 0 < contrast_min <= contrast_max and brightness_dn >= 0 required");
  }
  return true;
}

Texture make_photo_material(const PhotoSource& source, std::uint32_t seed, const PhotoMaterialOptions& o,
                            std::vector<MosaicPatch>* layout) {
  std::string err;
  if (!o.validate(&err)) throw std::runtime_error(err);
  if (source.frames.empty()) throw std::runtime_error("make_photo_material: no source images");
  for (const PhotoFrame& f : source.frames) {
    if (f.width < o.patch_max_px || f.height < o.patch_max_px) throw std::runtime_error("make_photo_material: source image smaller than a patch");
  }
  std::uint64_t rng = 0xC0FFEEULL * (static_cast<std::uint64_t>(seed) + 1);
  const int cells = o.size / o.grid_px;
  std::vector<PatchDraw> patches;
  for (int cj = 0; cj < cells; ++cj)
    for (int ci = 0; ci < cells; ++ci) patches.push_back(draw_patch(source, o, ci, cj, rng));
  if (layout) {
    layout->clear();
    for (const PatchDraw& d : patches) layout->push_back(d.place);
  }
  Texture t;
  t.size = o.size;
  t.texels_per_m = o.texels_per_m;
  t.mips.assign(1, std::vector<std::uint8_t>(static_cast<std::size_t>(o.size) * static_cast<std::size_t>(o.size)));
  for (int y = 0; y < o.size; ++y) {
    for (int x = 0; x < o.size; ++x) {
      const float value = mosaic_texel(patches, o, x, y);
      t.mips[0][static_cast<std::size_t>(y) * static_cast<std::size_t>(o.size) + static_cast<std::size_t>(x)] =
          static_cast<std::uint8_t>(std::clamp(value + 0.5f, 0.0f, 255.0f));
    }
  }
  t.build_mips();
  return t;
}

}  // namespace ums::sim
