#include "hal/sim/photo_renderer.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>
#include <thread>

#include "hal/sim/ray_cast.hpp"

namespace ums::sim {
namespace {

std::uint64_t mix64(std::uint64_t z) {
  z += 0x9E3779B97F4A7C15ULL;
  z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ULL;
  z = (z ^ (z >> 27)) * 0x94D049BB133111EBULL;
  return z ^ (z >> 31);
}

// Unit-variance noise from one 64-bit hash: sum of 4 uniforms (Irwin-Hall), rescaled.
float unit_noise(std::uint64_t r) {
  const float s4 = static_cast<float>(r & 0xFFFF) + static_cast<float>((r >> 16) & 0xFFFF) +
                   static_cast<float>((r >> 32) & 0xFFFF) + static_cast<float>(r >> 48);
  return (s4 / 65535.0f - 2.0f) * 1.7320508f;
}

}  // namespace

bool PhotoLensOptions::validate(std::string* error) const {
  if (!vignetting[0].validate(error) || !vignetting[1].validate(error)) return false;
  if (!(shot_noise_dn >= 0.0)) {
    if (error) *error = "PhotoLensOptions: shot_noise_dn must be >= 0";
    return false;
  }
  return true;
}

PhotoRenderer::PhotoRenderer(const World& world, const RigCalibration& rig, const PhotoLensOptions& lens)
    : world_(world), rig_(rig), lens_(lens) {
  std::string err;
  if (!lens.validate(&err)) throw std::runtime_error(err);
  if (world.boxes.size() > static_cast<std::size_t>(kMaxPhotoBoxes)) {
    throw std::runtime_error("PhotoRenderer: at most " + std::to_string(kMaxPhotoBoxes) + " boxes");
  }
  for (const Box& b : world.boxes) {
    const Eigen::Vector3f c = 0.5f * (b.lo + b.hi);
    box_sphere_.emplace_back(c.x(), c.y(), c.z(), 0.5f * (b.hi - b.lo).norm());
  }
  for (int c = 0; c < 2; ++c) {
    rays_[c] = make_camera_rays(rig.cam[c], c);
    vignetting_[c] = make_vignetting(rays_[c].bearing, rays_[c].width, rays_[c].height, lens.vignetting[c]);
    const int W = rays_[c].width, H = rays_[c].height;
    for (int ty = 0; ty < H; ty += kTile) {
      for (int tx = 0; tx < W; tx += kTile) {
        Eigen::Vector3f sum = Eigen::Vector3f::Zero();
        for (int v = ty; v < std::min(H, ty + kTile); ++v)
          for (int u = tx; u < std::min(W, tx + kTile); ++u) sum += rays_[c].bearing[static_cast<std::size_t>(v) * W + u];
        TileCone cone{sum.normalized(), 0.0f};
        for (int v = ty; v < std::min(H, ty + kTile); ++v)
          for (int u = tx; u < std::min(W, tx + kTile); ++u) {
            const float cosa = std::clamp(cone.axis_c.dot(rays_[c].bearing[static_cast<std::size_t>(v) * W + u]), -1.0f, 1.0f);
            cone.half_angle_rad = std::max(cone.half_angle_rad, std::acos(cosa));
          }
        tiles_[c].push_back(cone);
      }
    }
  }
}

// Boxes whose bounding sphere meets the tile's cone from any of the sub-exposure poses.
std::uint64_t PhotoRenderer::visible_boxes(const TileCone& cone, const SubPose* poses, int n_poses) const {
  std::uint64_t mask = 0;
  for (std::size_t b = 0; b < box_sphere_.size(); ++b) {
    const Eigen::Vector3f centre = box_sphere_[b].head<3>();
    const float r = box_sphere_[b].w();
    for (int j = 0; j < n_poses; ++j) {
      const Eigen::Vector3f v_c = poses[j].R_w_c.transpose() * (centre - poses[j].p_w_c);
      const float dist = v_c.norm();
      bool visible = dist <= r * 1.01f + 1e-3f;
      if (!visible) {
        const float angle = std::acos(std::clamp(cone.axis_c.dot(v_c) / dist, -1.0f, 1.0f));
        visible = angle <= cone.half_angle_rad + std::asin(std::min(1.0f, r / dist)) + 2e-3f;
      }
      if (visible) {
        mask |= std::uint64_t{1} << b;
        break;
      }
    }
  }
  return mask;
}

// Texel value x face shade x irradiance along the pixel's ray from one sub-exposure pose.
float PhotoRenderer::radiance(int cam, std::size_t idx, const SubPose& pose, std::uint64_t box_mask) const {
  const World& w = world_;
  const Eigen::Vector3f d = pose.R_w_c * rays_[cam].bearing[idx];
  const Eigen::Vector3f inv_d(1.0f / d.x(), 1.0f / d.y(), 1.0f / d.z());
  SurfaceHit hit = hit_room(w, pose.p_w_c, d, inv_d);
  for (std::uint64_t m = box_mask; m != 0; m &= m - 1) {
    hit_box(w, w.boxes[static_cast<std::size_t>(__builtin_ctzll(m))], pose.p_w_c, inv_d, &hit);
  }
  const Eigen::Vector3f x = pose.p_w_c + hit.t * d;
  const int ua = (hit.axis + 1) % 3, va = (hit.axis + 2) % 3;
  const Texture& tex = w.materials[static_cast<std::size_t>(hit.material)];
  const float cosi = std::max(0.15f, std::abs(d[hit.axis]));
  const float texels = hit.t * rays_[cam].footprint[idx] / cosi * tex.texels_per_m;
  Eigen::Vector3f normal = Eigen::Vector3f::Zero();
  normal[hit.axis] = d[hit.axis] > 0.0f ? -1.0f : 1.0f;  // faces the camera
  return tex.sample(x[ua], x[va], mip_level(texels)) * hit.shade * w.lighting.irradiance(x, normal);
}

void PhotoRenderer::render(int cam, const Eigen::Isometry3d* T_w_b, int n_poses, const RenderOptions& options,
                           std::uint64_t noise_key, std::uint8_t* out) const {
  if (n_poses < 1 || n_poses > kMaxSubExposures) throw std::runtime_error("PhotoRenderer: n_poses out of range");
  SubPose poses[kMaxSubExposures];
  for (int j = 0; j < n_poses; ++j) {
    const Eigen::Isometry3d T_w_c = T_w_b[j] * rig_.cam[cam].T_b_c;
    poses[j] = {T_w_c.rotation().cast<float>(), T_w_c.translation().cast<float>()};
  }
  const int W = rays_[cam].width, H = rays_[cam].height;
  const float scale = static_cast<float>(options.exposure_gain) / static_cast<float>(n_poses);
  const float read2 = static_cast<float>(options.noise_sigma_dn * options.noise_sigma_dn);
  const float shot = options.noise_sigma_dn > 0.0 ? static_cast<float>(lens_.shot_noise_dn) : 0.0f;
  const std::uint64_t key = mix64(noise_key * 0x100000001B3ULL + static_cast<std::uint64_t>(cam) + 0x5EEDULL);
  std::size_t tile = 0;
  for (int ty = 0; ty < H; ty += kTile) {
    for (int tx = 0; tx < W; tx += kTile, ++tile) {
      const std::uint64_t mask = visible_boxes(tiles_[cam][tile], poses, n_poses);
      for (int v = ty; v < std::min(H, ty + kTile); ++v) {
        for (int u = tx; u < std::min(W, tx + kTile); ++u) {
          const std::size_t idx = static_cast<std::size_t>(v) * W + u;
          float sum = 0.0f;
          for (int j = 0; j < n_poses; ++j) sum += radiance(cam, idx, poses[j], mask);
          float value = sum * scale * vignetting_[cam][idx];
          const float var = read2 + shot * std::max(value, 0.0f);
          if (var > 0.0f) value += std::sqrt(var) * unit_noise(mix64(key ^ (idx * 0x9E3779B97F4A7C15ULL)));
          out[idx] = static_cast<std::uint8_t>(std::clamp(value + 0.5f, 0.0f, 255.0f));
        }
      }
    }
  }
}

void PhotoRenderer::render_stereo(const Eigen::Isometry3d* T_w_b, int n_poses, const RenderOptions& options,
                                  std::uint64_t noise_key, std::uint8_t* left, std::uint8_t* right) const {
  // Checked here too: an exception on the helper thread would terminate.
  if (n_poses < 1 || n_poses > kMaxSubExposures) throw std::runtime_error("PhotoRenderer: n_poses out of range");
  std::thread t([&] { render(1, T_w_b, n_poses, options, noise_key, right); });
  render(0, T_w_b, n_poses, options, noise_key, left);
  t.join();
}

}  // namespace ums::sim
