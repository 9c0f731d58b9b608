#include "hal/sim/renderer.hpp"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <stdexcept>
#include <string>
#include <thread>

#include "hal/sim/camera_rays.hpp"
#include "hal/sim/ray_cast.hpp"

namespace ums::sim {
namespace {

std::uint32_t hash3(std::uint32_t a, std::uint32_t b, std::uint32_t c) {
  std::uint32_t h = a * 0x9E3779B1u ^ (b + 0x7F4A7C15u) * 0x85EBCA77u ^ (c + 0x165667B1u) * 0xC2B2AE3Du;
  h ^= h >> 15;
  h *= 0x2C1B3C6Du;
  h ^= h >> 12;
  h *= 0x297A2D39u;
  h ^= h >> 15;
  return h;
}

std::uint64_t splitmix(std::uint64_t& s) {
  std::uint64_t z = (s += 0x9E3779B97F4A7C15ULL);
  z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ULL;
  z = (z ^ (z >> 27)) * 0x94D049BB133111EBULL;
  return z ^ (z >> 31);
}

}  // namespace

void Texture::build_mips() {
  mips.resize(1);
  int s = size;
  while (s > 1) {
    const auto& src = mips.back();
    const int n = s / 2;
    std::vector<std::uint8_t> dst(static_cast<std::size_t>(n) * n);
    for (int y = 0; y < n; ++y) {
      for (int x = 0; x < n; ++x) {
        const int sum = src[(2 * y) * s + 2 * x] + src[(2 * y) * s + 2 * x + 1] + src[(2 * y + 1) * s + 2 * x] +
                        src[(2 * y + 1) * s + 2 * x + 1];
        dst[static_cast<std::size_t>(y) * n + x] = static_cast<std::uint8_t>((sum + 2) / 4);
      }
    }
    mips.push_back(std::move(dst));
    s = n;
  }
}

float Texture::sample(float u_m, float v_m, int level) const {
  level = std::clamp(level, 0, static_cast<int>(mips.size()) - 1);
  const int n = size >> level;
  const float scale = texels_per_m / static_cast<float>(1 << level);
  // Texel i's centre sits at (i + 0.5) / scale metres.
  const float su = u_m * scale - 0.5f, sv = v_m * scale - 0.5f;
  const float fu = std::floor(su), fv = std::floor(sv);
  const float au = su - fu, av = sv - fv;
  const int mask = n - 1;
  const int x0 = static_cast<int>(fu) & mask, y0 = static_cast<int>(fv) & mask;
  const int x1 = (x0 + 1) & mask, y1 = (y0 + 1) & mask;
  const std::uint8_t* t = mips[static_cast<std::size_t>(level)].data();
  const float a = t[y0 * n + x0], b = t[y0 * n + x1], c = t[y1 * n + x0], d = t[y1 * n + x1];
  return (a + (b - a) * au) * (1.0f - av) + (c + (d - c) * au) * av;
}

Texture make_textured_material(std::uint32_t seed, int size, float texels_per_m) {
  Texture t;
  t.size = size;
  t.texels_per_m = texels_per_m;
  t.mips.assign(1, std::vector<std::uint8_t>(static_cast<std::size_t>(size) * size));
  // Octaves of piecewise-constant cells 4..128 texels; a random subset of cells per octave is
  // "painted" so large flat patches with sharp corners alternate with fine detail.
  for (int y = 0; y < size; ++y) {
    for (int x = 0; x < size; ++x) {
      float v = 0.0f;
      for (int k = 2; k <= 7; ++k) {
        const std::uint32_t h = hash3(static_cast<std::uint32_t>(x >> k), static_cast<std::uint32_t>(y >> k),
                                      seed * 16u + static_cast<std::uint32_t>(k));
        const float cell = static_cast<float>(h & 0xFFFFu) / 65535.0f - 0.5f;
        const float weight = ((h >> 16) & 3u) == 0u ? 0.0f : 1.0f;
        v += weight * cell;
      }
      const float value = 128.0f + 70.0f * v;
      t.mips[0][static_cast<std::size_t>(y) * size + x] =
          static_cast<std::uint8_t>(std::clamp(value, 10.0f, 245.0f));
    }
  }
  t.build_mips();
  return t;
}

Texture make_textureless_material(std::uint32_t seed, int size, float texels_per_m) {
  Texture t;
  t.size = size;
  t.texels_per_m = texels_per_m;
  t.mips.assign(1, std::vector<std::uint8_t>(static_cast<std::size_t>(size) * size));
  const float ph = static_cast<float>(seed % 97u) * 0.1f;
  const float two_pi = 6.2831853f;
  for (int y = 0; y < size; ++y) {
    for (int x = 0; x < size; ++x) {
      // Faint shading: +-4 DN over wavelengths of the whole tile (8 m at the defaults).
      const float u = static_cast<float>(x) / static_cast<float>(size), v = static_cast<float>(y) / static_cast<float>(size);
      const float s = 150.0f + 3.0f * std::sin(two_pi * u + ph) + 2.0f * std::cos(two_pi * (u + v) + 0.5f * ph);
      t.mips[0][static_cast<std::size_t>(y) * size + x] = static_cast<std::uint8_t>(s);
    }
  }
  t.build_mips();
  return t;
}

bool WorldOptions::validate(std::string* error) const {
  if (margin_xy_m < 1.5 || margin_xy_m > 4.0) {
    if (error) *error = "WorldOptions.margin_xy_m must be in [1.5, 4] m, got " + std::to_string(margin_xy_m);
    return false;
  }
  if (texture_size < 64 || texture_size > 4096 || (texture_size & (texture_size - 1)) != 0) {
    if (error) *error = "WorldOptions.texture_size must be a power of two in [64, 4096], got " + std::to_string(texture_size);
    return false;
  }
  if (boxes < 0 || boxes > 32) {
    if (error) *error = "WorldOptions.boxes must be in [0, 32], got " + std::to_string(boxes);
    return false;
  }
  return true;
}

bool RenderOptions::validate(std::string* error) const {
  if (!(noise_sigma_dn >= 0.0) || !(exposure_gain > 0.0)) {
    if (error) *error = "RenderOptions: noise_sigma_dn >= 0 and exposure_gain > 0 required";
    return false;
  }
  return true;
}

World make_world(const std::vector<Eigen::Vector3d>& path_w, const WorldOptions& o) {
  std::string err;
  if (!o.validate(&err)) throw std::runtime_error(err);
  if (path_w.empty()) throw std::runtime_error("make_world: empty path");
  Eigen::Vector3d lo = path_w[0], hi = path_w[0];
  for (const auto& p : path_w) {
    lo = lo.cwiseMin(p);
    hi = hi.cwiseMax(p);
  }
  World w;
  w.room_lo = (lo - Eigen::Vector3d(o.margin_xy_m, o.margin_xy_m, o.margin_down_m)).cast<float>();
  w.room_hi = (hi + Eigen::Vector3d(o.margin_xy_m, o.margin_xy_m, o.margin_up_m)).cast<float>();
  // Materials: 0..5 textured faces, 6 textureless, 7.. boxes.
  // A tile always spans 4 m; a smaller texture_size only lowers the finest detail.
  const float tpm = static_cast<float>(o.texture_size) / 4.0f;
  for (std::uint32_t m = 0; m < 6; ++m) w.materials.push_back(make_textured_material(o.seed * 131u + m, o.texture_size, tpm));
  w.materials.push_back(make_textureless_material(o.seed));
  for (int f = 0; f < 6; ++f) {
    const bool wall_or_ceiling = f != 4;
    w.face_material[static_cast<std::size_t>(f)] = (o.textureless_walls && wall_or_ceiling) ? 6 : f;
  }
  w.face_shade = {0.85f, 0.9f, 0.8f, 0.95f, 1.0f, 0.7f};
  std::uint64_t s = 0x5151ULL + o.seed;
  auto uni = [&](double a, double b) {
    return a + (b - a) * static_cast<double>(splitmix(s) >> 11) * (1.0 / 9007199254740992.0);
  };
  int placed = 0;
  for (int attempt = 0; attempt < 400 && placed < o.boxes; ++attempt) {
    // One draw per statement, z before y before x (random_vector.hpp says why).
    const double size_z = uni(0.5, 1.8), size_y = uni(0.4, 1.2), size_x = uni(0.4, 1.2);
    const Eigen::Vector3d size(size_x, size_y, size_z);
    const Eigen::Vector3d rlo = w.room_lo.cast<double>(), rhi = w.room_hi.cast<double>();
    const double cy = uni(rlo.y() + 0.3 + size.y() / 2, rhi.y() - 0.3 - size.y() / 2);
    const double cx = uni(rlo.x() + 0.3 + size.x() / 2, rhi.x() - 0.3 - size.x() / 2);
    const Eigen::Vector3d c(cx, cy, rlo.z() + size.z() / 2);
    const Eigen::Vector3d blo = c - size / 2, bhi = c + size / 2;
    bool clear = true;
    for (std::size_t i = 0; i < path_w.size() && clear; i += 2) {
      const Eigen::Vector3d q = path_w[i].cwiseMax(blo).cwiseMin(bhi);
      clear = (q - path_w[i]).norm() > o.box_clearance_m;
    }
    if (!clear) continue;
    Box b;
    b.lo = blo.cast<float>();
    b.hi = bhi.cast<float>();
    b.material = static_cast<int>(w.materials.size());
    w.materials.push_back(make_textured_material(o.seed * 977u + 7919u * static_cast<std::uint32_t>(placed),
                                                 std::max(64, o.texture_size / 2), tpm));
    w.boxes.push_back(b);
    ++placed;
  }
  return w;
}

StereoRenderer::StereoRenderer(const World& world, const RigCalibration& rig) : world_(world), rig_(rig) {
  for (int c = 0; c < 2; ++c) {
    CameraRays rays = make_camera_rays(rig.cam[c], c);
    bearing_[c] = std::move(rays.bearing);
    footprint_[c] = std::move(rays.footprint);
  }
}

void StereoRenderer::render(int cam, const Eigen::Isometry3d& T_w_b, const RenderOptions& options,
                            std::uint64_t noise_key, std::uint8_t* out, int row_begin, int row_end) const {
  const CameraCalibration& cc = rig_.cam[cam];
  if (row_end < 0) row_end = cc.height;
  const Eigen::Isometry3d T_w_c = T_w_b * cc.T_b_c;
  const Eigen::Matrix3f R = T_w_c.rotation().cast<float>();
  const Eigen::Vector3f o = T_w_c.translation().cast<float>();
  const World& w = world_;
  const float gain = static_cast<float>(options.exposure_gain);
  const float sigma = static_cast<float>(options.noise_sigma_dn);
  for (int v = row_begin; v < row_end; ++v) {
    std::uint64_t rng = noise_key * 0x100000001B3ULL + static_cast<std::uint64_t>(cam) * 1000003ULL +
                        static_cast<std::uint64_t>(v) * 7919ULL;
    std::uint8_t* row = out + static_cast<std::size_t>(v) * cc.width;
    for (int u = 0; u < cc.width; ++u) {
      const std::size_t idx = static_cast<std::size_t>(v) * cc.width + u;
      const Eigen::Vector3f d = R * bearing_[cam][idx];
      const Eigen::Vector3f inv_d(1.0f / d.x(), 1.0f / d.y(), 1.0f / d.z());
      SurfaceHit hit = hit_room(w, o, d, inv_d);
      for (const Box& b : w.boxes) hit_box(w, b, o, inv_d, &hit);
      const Eigen::Vector3f x = o + hit.t * d;
      const int ua = (hit.axis + 1) % 3, va = (hit.axis + 2) % 3;
      const Texture& tex = w.materials[static_cast<std::size_t>(hit.material)];
      // Footprint on the surface: range * pixel angle / cos(incidence), in texels -> mip level.
      const float cosi = std::max(0.15f, std::abs(d[hit.axis]));
      const float texels = hit.t * footprint_[cam][idx] / cosi * tex.texels_per_m;
      float value = tex.sample(x[ua], x[va], mip_level(texels)) * hit.shade * gain;
      if (sigma > 0.0f) {
        // Sum of 4 uniforms (Irwin-Hall), scaled to unit variance: Gaussian enough for sensor noise.
        const std::uint64_t r = splitmix(rng);
        const float s4 = static_cast<float>(r & 0xFFFF) + static_cast<float>((r >> 16) & 0xFFFF) +
                         static_cast<float>((r >> 32) & 0xFFFF) + static_cast<float>(r >> 48);
        value += sigma * (s4 / 65535.0f - 2.0f) * 1.7320508f;
      }
      row[u] = static_cast<std::uint8_t>(std::clamp(value + 0.5f, 0.0f, 255.0f));
    }
  }
}

void StereoRenderer::render_stereo(const Eigen::Isometry3d& T_w_b, const RenderOptions& options,
                                   std::uint64_t noise_key, std::uint8_t* left, std::uint8_t* right) const {
  std::thread t([&] { render(1, T_w_b, options, noise_key, right); });
  render(0, T_w_b, options, noise_key, left);
  t.join();
}

}  // namespace ums::sim
