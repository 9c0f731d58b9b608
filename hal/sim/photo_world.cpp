#include "hal/sim/photo_world.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>

namespace ums::sim {
namespace {

struct Rng {
  std::uint64_t s;
  double uniform(double a, double b) {
    std::uint64_t z = (s += 0x9E3779B97F4A7C15ULL);
    z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ULL;
    z = (z ^ (z >> 27)) * 0x94D049BB133111EBULL;
    z ^= z >> 31;
    return a + (b - a) * static_cast<double>(z >> 11) * (1.0 / 9007199254740992.0);
  }
};

bool clear_of_path(const std::vector<Eigen::Vector3d>& path_w, const Eigen::Vector3d& lo, const Eigen::Vector3d& hi,
                   double clearance_m) {
  for (const Eigen::Vector3d& p : path_w) {
    if ((p.cwiseMax(lo).cwiseMin(hi) - p).norm() <= clearance_m) return false;
  }
  return true;
}

// Boxes and pillars stand beside the path (box_distance_min_m..max_m from a random path point),
// so they are seen from close and far while the walls stay far.
void place_boxes(const std::vector<Eigen::Vector3d>& path_w, const PhotoWorldOptions& o, int first_material,
                 Rng& rng, World* w) {
  const Eigen::Vector3d rlo = w->room_lo.cast<double>(), rhi = w->room_hi.cast<double>();
  const int want = o.boxes + o.pillars;
  int placed = 0;
  for (int attempt = 0; attempt < 60 * want && placed < want; ++attempt) {
    const bool pillar = placed >= o.boxes;
    const double side = pillar ? rng.uniform(0.3, 0.8) : 0.0;
    // Mostly small boxes, every third one large (crates, machines).
    const double big = placed % 3 == 0 ? 3.0 : 1.2;
    Eigen::Vector3d size(side, side, rhi.z() - rlo.z());
    if (!pillar) {  // one draw per statement, z before y before x (random_vector.hpp says why)
      size.z() = rng.uniform(0.3, 0.5 + big / 1.5);
      size.y() = rng.uniform(0.3, big);
      size.x() = rng.uniform(0.3, big);
    }
    const Eigen::Vector3d& anchor = path_w[static_cast<std::size_t>(rng.uniform(0.0, 1.0) * static_cast<double>(path_w.size() - 1))];
    const double heading = rng.uniform(0.0, 2.0 * M_PI), dist = rng.uniform(o.box_distance_min_m, o.box_distance_max_m);
    Eigen::Vector3d lo(anchor.x() + dist * std::cos(heading) - size.x() / 2, anchor.y() + dist * std::sin(heading) - size.y() / 2, rlo.z());
    lo.x() = std::clamp(lo.x(), rlo.x() + 0.2, rhi.x() - 0.2 - size.x());
    lo.y() = std::clamp(lo.y(), rlo.y() + 0.2, rhi.y() - 0.2 - size.y());
    const Eigen::Vector3d hi = lo + size;
    if (!clear_of_path(path_w, lo, hi, o.box_clearance_m)) continue;
    Box b;
    b.lo = lo.cast<float>();
    b.hi = hi.cast<float>();
    b.material = first_material + static_cast<int>(rng.uniform(0.0, 1.0) * o.box_materials) % o.box_materials;
    w->boxes.push_back(b);
    ++placed;
  }
}

}  // namespace

bool PhotoWorldOptions::validate(std::string* error) const {
  auto bad = [&](const std::string& m) {
    if (error) *error = "PhotoWorldOptions: " + m;
    return false;
  };
  if (!(wall_distance_min_m >= 1.0 && wall_distance_max_m >= wall_distance_min_m && wall_distance_max_m <= 50.0)) {
    return bad("wall distances must satisfy 1 <= min <= max <= 50 m");
  }
  if (!(floor_below_min_m >= 0.1 && floor_below_max_m >= floor_below_min_m)) return bad("floor_below range invalid");
  if (!(ceiling_above_min_m >= 0.5 && ceiling_above_max_m >= ceiling_above_min_m)) return bad("ceiling_above range invalid");
  if (boxes < 0 || pillars < 0 || boxes + pillars > 64) return bad("boxes + pillars must be in [0, 64]");
  if (box_materials < 1 || box_materials > 16) return bad("box_materials must be in [1, 16]");
  if (texture_size < 256 || texture_size > 4096 || (texture_size & (texture_size - 1)) != 0) {
    return bad("texture_size must be a power of two in [256, 4096]");
  }
  if (lights < 0 || lights > 16) return bad("lights must be in [0, 16]");
  return true;
}

World make_photo_world(const std::vector<Eigen::Vector3d>& path_w, const PhotoWorldOptions& o, const PhotoSource& source) {
  std::string err;
  if (!o.validate(&err)) throw std::runtime_error(err);
  if (path_w.empty()) throw std::runtime_error("make_photo_world: empty path");
  Eigen::Vector3d lo = path_w[0], hi = path_w[0];
  for (const auto& p : path_w) {
    lo = lo.cwiseMin(p);
    hi = hi.cwiseMax(p);
  }
  Rng rng{0xF07057ULL + 1000003ULL * o.seed};
  World w;
  // One draw per statement, z before y before x (random_vector.hpp says why).
  Eigen::Vector3d below, above;
  below.z() = rng.uniform(o.floor_below_min_m, o.floor_below_max_m);
  below.y() = rng.uniform(o.wall_distance_min_m, o.wall_distance_max_m);
  below.x() = rng.uniform(o.wall_distance_min_m, o.wall_distance_max_m);
  above.z() = rng.uniform(o.ceiling_above_min_m, o.ceiling_above_max_m);
  above.y() = rng.uniform(o.wall_distance_min_m, o.wall_distance_max_m);
  above.x() = rng.uniform(o.wall_distance_min_m, o.wall_distance_max_m);
  w.room_lo = (lo - below).cast<float>();
  w.room_hi = (hi + above).cast<float>();
  // Materials: 0..5 faces, 6 textureless, 7.. the boxes' pool.
  PhotoMaterialOptions mo;
  mo.size = o.texture_size;
  if (o.texture_size < 1024) {
    // Test-sized textures: cells of an eighth of the texture, patches scaled with them.
    mo.grid_px = o.texture_size / 8;
    mo.blend_px = mo.grid_px / 4;
    mo.patch_min_px = static_cast<int>(std::ceil(2.0 * (std::sqrt(2.0) * 0.75 * mo.grid_px + 8.0)));
    mo.patch_max_px = mo.patch_min_px + mo.grid_px / 4;
  }
  for (int m = 0; m < 6 + o.box_materials; ++m) {
    if (m == 6) w.materials.push_back(make_textureless_material(o.seed));
    mo.texels_per_m = static_cast<float>(rng.uniform(96.0, 192.0));
    w.materials.push_back(make_photo_material(source, o.seed * 131u + static_cast<std::uint32_t>(m), mo));
  }
  for (int f = 0; f < 6; ++f) {
    const bool wall_or_ceiling = f != 4;
    w.face_material[static_cast<std::size_t>(f)] = (o.textureless_walls && wall_or_ceiling) ? 6 : f;
    w.face_shade[static_cast<std::size_t>(f)] = static_cast<float>(rng.uniform(0.75, 1.0));
  }
  place_boxes(path_w, o, 7, rng, &w);
  LightingOptions lo_opts;
  lo_opts.lights = o.lights;
  lo_opts.seed = o.seed;
  w.lighting = make_lighting(w.room_lo, w.room_hi, lo_opts);
  return w;
}

}  // namespace ums::sim
