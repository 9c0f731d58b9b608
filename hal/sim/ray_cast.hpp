#pragma once
// Ray casting against the simulated world (room seen from inside, axis-aligned boxes), shared
// by the procedural renderer (renderer.cpp) and the photo renderer (photo_renderer.cpp). Inline:
// these run once per pixel and sub-exposure.

#include <cstdint>
#include <cstring>
#include <utility>

#include <Eigen/Core>

#include "hal/sim/renderer.hpp"

namespace ums::sim {

struct SurfaceHit {
  float t = 1e30f;     // range along the ray (unit ray: m)
  int axis = 0;        // axis of the surface normal
  int positive = 0;    // face index 2 * axis + positive (room: the +axis wall; box: outward normal +axis)
  int material = 0;    // index into World::materials
  float shade = 1.0f;  // World::face_shade of the face orientation
};

// The room's nearest exit plane along o + t d.
inline SurfaceHit hit_room(const World& w, const Eigen::Vector3f& o, const Eigen::Vector3f& d,
                           const Eigen::Vector3f& inv_d) {
  SurfaceHit hit;
  for (int a = 0; a < 3; ++a) {
    // A ray parallel to a pair of walls never meets them: (lo - o) * inf would be -inf and win
    // (a camera axis-aligned with the room, as the car's on its straights, had a black row).
    if (d[a] == 0.0f) continue;
    const bool pos = d[a] > 0.0f;
    const float t = ((pos ? w.room_hi[a] : w.room_lo[a]) - o[a]) * inv_d[a];
    if (t < hit.t) {
      hit.t = t;
      hit.axis = a;
      hit.positive = pos ? 1 : 0;
    }
  }
  hit.material = w.face_material[static_cast<std::size_t>(2 * hit.axis + hit.positive)];
  hit.shade = w.face_shade[static_cast<std::size_t>(2 * hit.axis + hit.positive)];
  return hit;
}

// Slab test; replaces *hit when the box is entered in front of the origin and nearer.
inline void hit_box(const World& w, const Box& b, const Eigen::Vector3f& o, const Eigen::Vector3f& inv_d,
                    SurfaceHit* hit) {
  float tn = -1e30f, tf = 1e30f;
  int na = 0, np = 0;
  for (int a = 0; a < 3; ++a) {
    float t0 = (b.lo[a] - o[a]) * inv_d[a], t1 = (b.hi[a] - o[a]) * inv_d[a];
    // Moving in +a the ray enters through the low face (outward normal -a: index 2a).
    int p = 0;
    if (t0 > t1) {
      std::swap(t0, t1);
      p = 1;
    }
    if (t0 > tn) {
      tn = t0;
      na = a;
      np = p;
    }
    tf = std::min(tf, t1);
  }
  if (tn <= tf && tn > 1e-4f && tn < hit->t) {
    hit->t = tn;
    hit->axis = na;
    hit->positive = np;
    hit->material = b.material;
    hit->shade = w.face_shade[static_cast<std::size_t>(2 * na + np)];
  }
}

// Nearest mip level for a footprint of `texels` texels: round(log2(texels)), read from the
// float exponent of texels * sqrt(2).
inline int mip_level(float texels) {
  if (!(texels > 1.0f)) return 0;
  std::uint32_t bits;
  const float scaled = texels * 1.41421356f;
  std::memcpy(&bits, &scaled, sizeof bits);
  return static_cast<int>((bits >> 23) & 0xFFu) - 127;
}

}  // namespace ums::sim
