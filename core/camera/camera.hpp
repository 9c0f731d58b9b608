#pragma once
// Pinhole camera with radial-tangential (EuRoC, Kalibr "radtan") or equidistant (Kalibr
// "equidistant" = Kannala-Brandt without the linear term) distortion. Scalar is float on the
// front end's hot path and double in the estimator; the same template serves both.
//
// Conventions. p_c: a point in the camera frame (z forward, x right, y down). "Normalized" means
// the undistorted image plane z = 1 (x/z, y/z); "bearing" is the unit vector p_c / |p_c|. Pixels
// uv follow the image: u = column, v = row, the centre of the top-left pixel is (0, 0).
//
// Models (Kalibr definitions):
//   radtan:      r2 = x^2 + y^2, s = 1 + k1 r2 + k2 r2^2
//                x_d = s x + 2 p1 x y + p2 (r2 + 2 x^2),  y_d = s y + p1 (r2 + 2 y^2) + 2 p2 x y
//   equidistant: r = |(x, y)|, th = atan(r), th_d = th (1 + k1 th^2 + k2 th^4 + k3 th^6 + k4 th^8)
//                (x_d, y_d) = (th_d / r) (x, y)
//   then u = fx x_d + cx, v = fy y_d + cy.
// Undistortion of a point inverts the distortion by Gauss-Newton on the 2x2 Jacobian (radtan) or
// by Newton on th (equidistant), with a fixed iteration bound; no image is ever undistorted.

#include <array>
#include <cmath>

#include <Eigen/Core>

#include "core/common/calibration.hpp"

namespace ums {

template <typename Scalar>
class CameraT {
 public:
  using Vec2 = Eigen::Matrix<Scalar, 2, 1>;
  using Vec3 = Eigen::Matrix<Scalar, 3, 1>;
  using Mat22 = Eigen::Matrix<Scalar, 2, 2>;
  using Mat23 = Eigen::Matrix<Scalar, 2, 3>;

  static constexpr int kUndistortIterations = 20;  // Gauss-Newton bound; converges in 3-6

  CameraT() = default;
  CameraT(CameraModel model, int width, int height, Scalar fx, Scalar fy, Scalar cx, Scalar cy,
          const std::array<Scalar, 4>& distortion)
      : model_(model), width_(width), height_(height), fx_(fx), fy_(fy), cx_(cx), cy_(cy),
        d_(distortion) {}

  static CameraT from_calibration(const CameraCalibration& c) {
    std::array<Scalar, 4> d{};
    for (int i = 0; i < 4; ++i) d[static_cast<std::size_t>(i)] = static_cast<Scalar>(c.distortion[static_cast<std::size_t>(i)]);
    return CameraT(c.model, c.width, c.height, static_cast<Scalar>(c.fx), static_cast<Scalar>(c.fy),
                   static_cast<Scalar>(c.cx), static_cast<Scalar>(c.cy), d);
  }

  CameraModel model() const { return model_; }
  int width() const { return width_; }
  int height() const { return height_; }
  Scalar fx() const { return fx_; }
  Scalar fy() const { return fy_; }
  Scalar cx() const { return cx_; }
  Scalar cy() const { return cy_; }
  const std::array<Scalar, 4>& distortion() const { return d_; }

  bool in_image(const Vec2& uv, Scalar border_px = Scalar(0)) const {
    return uv.x() >= border_px && uv.y() >= border_px && uv.x() <= Scalar(width_ - 1) - border_px &&
           uv.y() <= Scalar(height_ - 1) - border_px;
  }

  // Distortion of a normalized point, with its 2x2 Jacobian d_xd_d_xy when asked.
  Vec2 distort(const Vec2& xy, Mat22* d_xd_d_xy = nullptr) const {
    const Scalar x = xy.x(), y = xy.y();
    if (model_ == CameraModel::kPinholeRadTan) {
      const Scalar k1 = d_[0], k2 = d_[1], p1 = d_[2], p2 = d_[3];
      const Scalar r2 = x * x + y * y;
      const Scalar s = Scalar(1) + k1 * r2 + k2 * r2 * r2;
      Vec2 out(s * x + Scalar(2) * p1 * x * y + p2 * (r2 + Scalar(2) * x * x),
               s * y + p1 * (r2 + Scalar(2) * y * y) + Scalar(2) * p2 * x * y);
      if (d_xd_d_xy != nullptr) {
        const Scalar ds_dr2 = k1 + Scalar(2) * k2 * r2;  // d s / d r2; d r2 / dx = 2x
        Mat22& J = *d_xd_d_xy;
        J(0, 0) = s + Scalar(2) * x * x * ds_dr2 + Scalar(2) * p1 * y + Scalar(6) * p2 * x;
        J(0, 1) = Scalar(2) * x * y * ds_dr2 + Scalar(2) * p1 * x + Scalar(2) * p2 * y;
        J(1, 0) = Scalar(2) * x * y * ds_dr2 + Scalar(2) * p1 * x + Scalar(2) * p2 * y;
        J(1, 1) = s + Scalar(2) * y * y * ds_dr2 + Scalar(6) * p1 * y + Scalar(2) * p2 * x;
      }
      return out;
    }
    // Equidistant.
    const Scalar r2 = x * x + y * y;
    const Scalar r = std::sqrt(r2);
    if (r < Scalar(1e-7)) {
      if (d_xd_d_xy != nullptr) d_xd_d_xy->setIdentity();
      return xy;
    }
    const Scalar th = std::atan(r);
    const Scalar th2 = th * th;
    const Scalar poly = Scalar(1) + th2 * (d_[0] + th2 * (d_[1] + th2 * (d_[2] + th2 * d_[3])));
    const Scalar th_d = th * poly;
    const Scalar scale = th_d / r;
    if (d_xd_d_xy != nullptr) {
      // d th_d / d th = 1 + 3 k1 th^2 + 5 k2 th^4 + 7 k3 th^6 + 9 k4 th^8; d th / d r = 1/(1+r^2)
      const Scalar dthd_dth =
          Scalar(1) + th2 * (Scalar(3) * d_[0] + th2 * (Scalar(5) * d_[1] + th2 * (Scalar(7) * d_[2] + th2 * Scalar(9) * d_[3])));
      const Scalar dthd_dr = dthd_dth / (Scalar(1) + r2);
      const Scalar dscale_dr = (dthd_dr * r - th_d) / r2;
      // d (scale x) / dx = scale + x dscale/dr * x/r
      Mat22& J = *d_xd_d_xy;
      J(0, 0) = scale + x * x / r * dscale_dr;
      J(0, 1) = x * y / r * dscale_dr;
      J(1, 0) = J(0, 1);
      J(1, 1) = scale + y * y / r * dscale_dr;
    }
    return Vec2(scale * x, scale * y);
  }

  // Normalized undistorted point from a pixel. Returns false when the iteration did not converge
  // (far outside the calibrated field of view) or the ray is 90 degrees or more off axis.
  bool undistort_point(const Vec2& uv, Vec2* xy) const {
    const Vec2 xd((uv.x() - cx_) / fx_, (uv.y() - cy_) / fy_);
    if (model_ == CameraModel::kPinholeEquidistant) {
      Scalar th = 0, r_d = 0;
      if (!equidistant_theta(xd, &th, &r_d)) return false;
      if (r_d < Scalar(1e-7)) {
        *xy = xd;
        return true;
      }
      if (th >= Scalar(1.5707)) return false;
      *xy = xd * (std::tan(th) / r_d);
      return true;
    }
    // Radtan: Gauss-Newton on distort(xy) = xd starting at xd.
    Vec2 p = xd;
    Mat22 J;
    for (int it = 0; it < kUndistortIterations; ++it) {
      const Vec2 e = distort(p, &J) - xd;
      const Vec2 step = J.inverse() * e;  // 2x2: closed form
      p -= step;
      if (step.squaredNorm() < Scalar(1e-14)) break;
    }
    const Vec2 check = distort(p) - xd;
    if (!(check.squaredNorm() < Scalar(1e-8))) return false;
    *xy = p;
    return true;
  }

  // Unit bearing from a pixel (equidistant: also rays beyond 90 degrees, z <= 0).
  bool unproject(const Vec2& uv, Vec3* bearing) const {
    if (model_ == CameraModel::kPinholeEquidistant) {
      const Vec2 xd((uv.x() - cx_) / fx_, (uv.y() - cy_) / fy_);
      Scalar th = 0, r_d = 0;
      if (!equidistant_theta(xd, &th, &r_d)) return false;
      if (r_d < Scalar(1e-7)) {
        *bearing = Vec3(xd.x(), xd.y(), Scalar(1)).normalized();
        return true;
      }
      const Scalar s = std::sin(th) / r_d;
      *bearing = Vec3(s * xd.x(), s * xd.y(), std::cos(th));
      return true;
    }
    Vec2 xy;
    if (!undistort_point(uv, &xy)) return false;
    *bearing = Vec3(xy.x(), xy.y(), Scalar(1)).normalized();
    return true;
  }

  // Pixel of a point in the camera frame, with d_uv_d_p (2x3) when asked. False behind the camera.
  bool project(const Vec3& p_c, Vec2* uv, Mat23* d_uv_d_p = nullptr) const {
    if (!(p_c.z() > Scalar(1e-6))) return false;
    const Scalar inv_z = Scalar(1) / p_c.z();
    const Vec2 xy(p_c.x() * inv_z, p_c.y() * inv_z);
    Mat22 J;
    const Vec2 xd = distort(xy, d_uv_d_p != nullptr ? &J : nullptr);
    *uv = Vec2(fx_ * xd.x() + cx_, fy_ * xd.y() + cy_);
    if (d_uv_d_p != nullptr) {
      Mat23 d_xy_d_p;
      d_xy_d_p << inv_z, Scalar(0), -xy.x() * inv_z, Scalar(0), inv_z, -xy.y() * inv_z;
      Mat22 F;
      F << fx_, Scalar(0), Scalar(0), fy_;
      *d_uv_d_p = F * J * d_xy_d_p;
    }
    return true;
  }

 private:
  // Newton on th: th (1 + k1 th^2 + ...) = r_d, the distorted radius of xd.
  bool equidistant_theta(const Vec2& xd, Scalar* th_out, Scalar* r_d_out) const {
    const Scalar r_d = xd.norm();
    *r_d_out = r_d;
    Scalar th = r_d;
    for (int it = 0; it < kUndistortIterations; ++it) {
      const Scalar th2 = th * th;
      const Scalar f = th * (Scalar(1) + th2 * (d_[0] + th2 * (d_[1] + th2 * (d_[2] + th2 * d_[3])))) - r_d;
      const Scalar df = Scalar(1) + th2 * (Scalar(3) * d_[0] + th2 * (Scalar(5) * d_[1] +
                                                 th2 * (Scalar(7) * d_[2] + th2 * Scalar(9) * d_[3])));
      if (!(df > Scalar(0))) return false;
      const Scalar step = f / df;
      th -= step;
      if (std::abs(step) < Scalar(1e-9)) break;
    }
    *th_out = th;
    return std::isfinite(th) && th >= Scalar(0) && th < Scalar(3.14159);
  }

  CameraModel model_ = CameraModel::kPinholeRadTan;
  int width_ = 0;
  int height_ = 0;
  Scalar fx_ = 0, fy_ = 0, cx_ = 0, cy_ = 0;
  std::array<Scalar, 4> d_{};
};

using Camera = CameraT<float>;    // front end
using CameraD = CameraT<double>;  // estimator

extern template class CameraT<float>;
extern template class CameraT<double>;

}  // namespace ums
