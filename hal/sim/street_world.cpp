#include "hal/sim/street_world.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>

namespace ums::sim {
namespace {

// Material indices of the street world.
constexpr int kRoad = 0;
constexpr int kSky = 1;
constexpr int kFirstFacade = 2;
constexpr int kFacades = 4;

// Cells of the room's footprint that are farther than half_width from every path point
// (horizontal distance from the point to the cell's square).
std::vector<std::uint8_t> block_cells(const std::vector<Eigen::Vector3d>& path_w, const Eigen::Vector2d& lo, int nx,
                                      int ny, const StreetOptions& o) {
  std::vector<std::uint8_t> cell(static_cast<std::size_t>(nx) * ny, 1);
  for (int j = 0; j < ny; ++j) {
    for (int i = 0; i < nx; ++i) {
      const Eigen::Vector2d clo = lo + o.cell_m * Eigen::Vector2d(i, j);
      const Eigen::Vector2d chi = clo + Eigen::Vector2d::Constant(o.cell_m);
      for (const Eigen::Vector3d& p : path_w) {
        const Eigen::Vector2d q = p.head<2>().cwiseMax(clo).cwiseMin(chi);
        if ((q - p.head<2>()).norm() <= o.half_width_m) {
          cell[static_cast<std::size_t>(j) * nx + i] = 0;
          break;
        }
      }
    }
  }
  return cell;
}

// Row runs of block cells, runs of equal extent in consecutive rows merged into one rectangle:
// a handful of boxes (the renderer tests every box per pixel).
void add_blocks(const std::vector<std::uint8_t>& cell, const Eigen::Vector2d& lo, int nx, int ny,
                const StreetOptions& o, World* w) {
  struct Run {
    int i0, i1, j0;  // cells [i0, i1) from row j0
  };
  std::vector<Run> open;
  auto emit = [&](const Run& r, int j1) {
    Box b;
    b.lo = Eigen::Vector3f(static_cast<float>(lo.x() + o.cell_m * r.i0), static_cast<float>(lo.y() + o.cell_m * r.j0), 0.0f);
    b.hi = Eigen::Vector3f(static_cast<float>(lo.x() + o.cell_m * r.i1), static_cast<float>(lo.y() + o.cell_m * j1),
                           static_cast<float>(o.block_height_m));
    b.material = kFirstFacade + static_cast<int>(w->boxes.size() % kFacades);
    w->boxes.push_back(b);
  };
  for (int j = 0; j <= ny; ++j) {
    std::vector<Run> row;
    for (int i = 0; j < ny && i < nx;) {
      if (!cell[static_cast<std::size_t>(j) * nx + i]) {
        ++i;
        continue;
      }
      int e = i;
      while (e < nx && cell[static_cast<std::size_t>(j) * nx + e]) ++e;
      row.push_back({i, e, j});
      i = e;
    }
    std::vector<Run> next;
    for (const Run& r : open) {
      auto same = std::find_if(row.begin(), row.end(), [&](const Run& c) { return c.i0 == r.i0 && c.i1 == r.i1; });
      if (same != row.end()) {
        same->j0 = r.j0;  // continues the open rectangle
      } else {
        emit(r, j);
      }
    }
    open = row;
  }
}

}  // namespace

bool StreetOptions::validate(std::string* error) const {
  auto bad = [&](const std::string& m) {
    if (error) *error = "StreetOptions: " + m;
    return false;
  };
  if (!(half_width_m >= 3.0 && half_width_m <= 20.0)) return bad("half_width_m must be in [3, 20] m");
  if (!(block_height_m > 0.0 && block_height_m < sky_height_m)) return bad("block_height_m must be in (0, sky_height_m)");
  if (!(sky_height_m > 3.0 && sky_height_m <= 200.0)) return bad("sky_height_m must be in (3, 200] m");
  if (!(cell_m >= 0.25 && cell_m <= 5.0)) return bad("cell_m must be in [0.25, 5] m");
  if (texture_size < 64 || texture_size > 4096 || (texture_size & (texture_size - 1)) != 0) {
    return bad("texture_size must be a power of two in [64, 4096]");
  }
  return true;
}

World make_street_world(const std::vector<Eigen::Vector3d>& path_w, const StreetOptions& o) {
  std::string err;
  if (!o.validate(&err)) throw std::runtime_error(err);
  if (path_w.empty()) throw std::runtime_error("make_street_world: empty path");
  Eigen::Vector2d lo = path_w[0].head<2>(), hi = lo;
  for (const auto& p : path_w) {
    lo = lo.cwiseMin(p.head<2>());
    hi = hi.cwiseMax(p.head<2>());
  }
  // The room: whole cells from lo - half_width, so blocks and walls line up.
  lo -= Eigen::Vector2d::Constant(o.half_width_m);
  const int nx = static_cast<int>(std::ceil((hi.x() + o.half_width_m - lo.x()) / o.cell_m));
  const int ny = static_cast<int>(std::ceil((hi.y() + o.half_width_m - lo.y()) / o.cell_m));
  World w;
  w.room_lo = Eigen::Vector3f(static_cast<float>(lo.x()), static_cast<float>(lo.y()), 0.0f);
  w.room_hi = Eigen::Vector3f(static_cast<float>(lo.x() + nx * o.cell_m), static_cast<float>(lo.y() + ny * o.cell_m),
                              static_cast<float>(o.sky_height_m));
  const float tpm = static_cast<float>(o.texture_size) / 4.0f;  // a 4 m tile whatever the size
  w.materials.push_back(make_textured_material(o.seed * 131u + 11u, o.texture_size, tpm));
  // The sky: flat grey with faint shading over a 64 m tile, no corners.
  w.materials.push_back(make_textureless_material(o.seed, 256, 4.0f));
  for (std::uint32_t m = 0; m < kFacades; ++m) {
    w.materials.push_back(make_textured_material(o.seed * 131u + 17u * (m + 1u), o.texture_size, tpm));
  }
  w.face_material = {kFirstFacade, kFirstFacade + 1, kFirstFacade + 2, kFirstFacade + 3, kRoad, kSky};
  w.face_shade = {0.85f, 0.9f, 0.8f, 0.95f, 1.0f, 1.1f};
  add_blocks(block_cells(path_w, lo, nx, ny, o), lo, nx, ny, o, &w);
  return w;
}

}  // namespace ums::sim
