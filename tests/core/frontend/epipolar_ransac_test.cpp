#include "core/frontend/epipolar_ransac.hpp"

#include <cmath>

#include <Eigen/Geometry>
#include <catch2/catch.hpp>

namespace {

struct Scene {
  Eigen::Vector3f b0[300];
  Eigen::Vector3f b1[300];
  bool outlier[300];
};

// Points 2-10 m in front of camera 0; camera 1 moved by (R_1_0, t_1_0); a fraction replaced by
// random bearings; pixel noise sigma_px at focal 460.
void make_scene(Scene* s, int n, const Eigen::Matrix3d& R_1_0, const Eigen::Vector3d& t_1_0, double outlier_frac,
                double sigma_px) {
  ums::Xorshift32 rng;
  rng.state = 777u;
  auto u = [&rng]() { return static_cast<double>(rng.next() % 1000000u) / 1000000.0; };
  auto gauss = [&u]() { return std::sqrt(-2.0 * std::log(u() + 1e-12)) * std::cos(2.0 * M_PI * u()); };
  const double f = 460.0;
  for (int i = 0; i < n; ++i) {
    const Eigen::Vector3d p0(-3.0 + 6.0 * u(), -2.0 + 4.0 * u(), 2.0 + 8.0 * u());
    const Eigen::Vector3d p1 = R_1_0 * p0 + t_1_0;
    Eigen::Vector3d x0 = p0 / p0.z(), x1 = p1 / p1.z();
    x0.head<2>() += Eigen::Vector2d(gauss(), gauss()) * sigma_px / f;
    x1.head<2>() += Eigen::Vector2d(gauss(), gauss()) * sigma_px / f;
    s->outlier[i] = u() < outlier_frac;
    if (s->outlier[i]) x1.head<2>() += Eigen::Vector2d(u() - 0.5, u() - 0.5) * 0.2;  // up to +-46 px
    s->b0[i] = x0.normalized().cast<float>();
    s->b1[i] = x1.normalized().cast<float>();
  }
}

void check_separation(const Scene& s, int n, const std::uint8_t* inl, int* kept_good, int* kept_bad, int* n_good) {
  *kept_good = *kept_bad = *n_good = 0;
  for (int i = 0; i < n; ++i) {
    if (!s.outlier[i]) ++*n_good;
    if (inl[i] != 0) ++(s.outlier[i] ? *kept_bad : *kept_good);
  }
}

}  // namespace

TEST_CASE("RANSAC on bearings keeps true matches and rejects gross outliers (general motion)") {
  Scene s;
  const int n = 200;
  const Eigen::Matrix3d R = Eigen::AngleAxisd(0.05, Eigen::Vector3d(0.2, 1.0, 0.1).normalized()).toRotationMatrix();
  make_scene(&s, n, R, Eigen::Vector3d(0.3, 0.02, 0.05), 0.25, 0.3);
  std::uint8_t inl[300];
  int n_in = 0;
  ums::Xorshift32 rng;
  Eigen::Matrix3d E;
  REQUIRE(ums::ransac_essential(s.b0, s.b1, n, 460.0f, ums::RansacOptions{}, &rng, inl, &n_in, &E) == ums::Status::kOk);
  int good = 0, bad = 0, n_good = 0;
  check_separation(s, n, inl, &good, &bad, &n_good);
  INFO("kept good " << good << "/" << n_good << ", kept bad " << bad << "/" << (n - n_good));
  CHECK(good >= 0.95 * n_good);
  CHECK(bad <= 0.1 * (n - n_good));
}

TEST_CASE("RANSAC with a still camera keeps the still matches and rejects the moved ones") {
  Scene s;
  const int n = 150;
  make_scene(&s, n, Eigen::Matrix3d::Identity(), Eigen::Vector3d::Zero(), 0.2, 0.2);
  std::uint8_t inl[300];
  int n_in = 0;
  ums::Xorshift32 rng;
  REQUIRE(ums::ransac_essential(s.b0, s.b1, n, 460.0f, ums::RansacOptions{}, &rng, inl, &n_in) == ums::Status::kOk);
  int good = 0, bad = 0, n_good = 0;
  check_separation(s, n, inl, &good, &bad, &n_good);
  INFO("kept good " << good << "/" << n_good << ", kept bad " << bad << "/" << (n - n_good));
  CHECK(good >= 0.95 * n_good);
  CHECK(bad <= 0.25 * (n - n_good));
}

TEST_CASE("RANSAC is repeatable for a seed and keeps everything below 8 matches") {
  Scene s;
  make_scene(&s, 100, Eigen::Matrix3d::Identity(), Eigen::Vector3d(0.2, 0.0, 0.0), 0.3, 0.3);
  std::uint8_t a[300], b[300];
  int na = 0, nb = 0;
  ums::Xorshift32 r1, r2;
  ums::ransac_essential(s.b0, s.b1, 100, 460.0f, ums::RansacOptions{}, &r1, a, &na);
  ums::ransac_essential(s.b0, s.b1, 100, 460.0f, ums::RansacOptions{}, &r2, b, &nb);
  CHECK(na == nb);
  for (int i = 0; i < 100; ++i) CHECK(a[i] == b[i]);
  int n_few = 0;
  CHECK(ums::ransac_essential(s.b0, s.b1, 7, 460.0f, ums::RansacOptions{}, &r1, a, &n_few) == ums::Status::kNotEnoughData);
  CHECK(n_few == 7);
}
