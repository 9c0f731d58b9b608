#pragma once
// Lens vignetting for the photo style: a radial falloff of the image brightness,
//   gain(pixel) = cos(theta)^k,  theta = angle between the pixel's ray and the vignetting axis,
// (cos^4 is the natural falloff of a thin lens; real wide-angle modules are corrected towards
// less), with k solved so that the mean gain of the four corner pixels is corner_gain. The axis
// is the optical axis tilted by axis_tilt_rad (a decentred lens), so left and right cameras
// differ in strength and centre as real modules do.

#include <string>
#include <vector>

#include <Eigen/Core>

namespace ums::sim {

struct VignettingOptions {
  double corner_gain = 0.65;                                    // mean corner / centre, (0, 1]
  Eigen::Vector2d axis_tilt_rad = Eigen::Vector2d::Zero();     // tilt of the axis about camera y, x
  bool validate(std::string* error) const;
};

// One gain per pixel (rows packed) from the camera's unit bearings (width x height). Throws
// std::runtime_error on invalid options or a bearing table that does not match the size.
std::vector<float> make_vignetting(const std::vector<Eigen::Vector3f>& bearing_c, int width, int height,
                                   const VignettingOptions& options);

}  // namespace ums::sim
