// BRIEF-256 on the real micro sequence: the same corner in consecutive frames keeps its
// descriptor within a few bits, other corners are about half the bits away, a brightness offset
// changes nothing, and the pattern is the same on every build.
#include "core/loop/brief.hpp"

#include <catch2/catch.hpp>
#include <filesystem>
#include <opencv2/imgproc.hpp>
#include <string>
#include <vector>

#include "hal/replay/png_io.hpp"
#include "profiling/alloc_counter.hpp"
#include "tests/common/test_paths.hpp"

using namespace ums;
using namespace ums::loop;

namespace {

std::vector<std::string> micro_images() {
  std::vector<std::string> files;
  for (const auto& e : std::filesystem::directory_iterator(test::euroc_micro_dir() + "/mav0/cam0/data"))
    files.push_back(e.path().string());
  std::sort(files.begin(), files.end());
  return files;
}

cv::Mat load(const std::string& path) {
  cv::Mat img(480, 752, CV_8UC1);
  int w = 0, h = 0;
  std::string error;
  REQUIRE(hal::read_png_gray8(path, img.data, img.total(), &w, &h, &error));
  REQUIRE(w == 752);
  return img;
}

ImageView view_of(const cv::Mat& m) { return ImageView{m.data, m.cols, m.rows, static_cast<int>(m.step)}; }

}  // namespace

TEST_CASE("BRIEF pattern: 256 distinct pairs inside the patch, spread like a Gaussian of 6.2 px", "[loop]") {
  BriefDescriber a(752, 480), b(752, 480);
  double sum = 0.0, sum_sq = 0.0;
  for (int i = 0; i < 256; ++i) {
    const auto& p = a.pair(i);
    CHECK((p.x0 != p.x1 || p.y0 != p.y1));
    for (int v : {p.x0, p.y0, p.x1, p.y1}) {
      CHECK(std::abs(v) <= BriefDescriber::kPatchRadius);
      sum += v;
      sum_sq += v * v;
    }
    const auto& q = b.pair(i);
    CHECK((p.x0 == q.x0 && p.y0 == q.y0 && p.x1 == q.x1 && p.y1 == q.y1));  // fixed, not random per run
  }
  const double n = 1024.0;
  CHECK(std::abs(sum / n) < 0.6);
  CHECK(std::sqrt(sum_sq / n) == Approx(6.2).margin(0.6));
}

TEST_CASE("BRIEF on a micro frame seen again turned by 3 deg, shifted and noisier: the same corners keep their bits", "[loop]") {
  const cv::Mat img0 = load(micro_images()[40]);
  // The second view: rotated 3 deg about the image centre, shifted by (4.3, -2.6) px, with
  // 2 grey levels of noise, so every corner's position in it is known exactly.
  const cv::Mat A = cv::getRotationMatrix2D(cv::Point2f(376.0f, 240.0f), 3.0, 1.0);
  cv::Mat M;
  A.copyTo(M);
  M.at<double>(0, 2) += 4.3;
  M.at<double>(1, 2) += -2.6;
  cv::Mat img1;
  cv::warpAffine(img0, img1, M, img0.size(), cv::INTER_LINEAR, cv::BORDER_REPLICATE);
  cv::Mat noise(img1.size(), CV_16SC1);
  cv::randn(noise, 0.0, 2.0);
  cv::Mat img1s;
  img1.convertTo(img1s, CV_16SC1);
  img1s += noise;
  img1s.convertTo(img1, CV_8UC1);
  std::vector<cv::Point2f> corners0, corners1;
  cv::goodFeaturesToTrack(img0, corners0, 150, 0.01, 20.0);
  cv::transform(corners0, corners1, M);
  BriefDescriber describer(752, 480);
  std::vector<Descriptor> d0(corners0.size()), d1(corners0.size());
  std::vector<int> ok(corners0.size(), 0);
  REQUIRE(describer.set_image(view_of(img0)));
  for (std::size_t i = 0; i < corners0.size(); ++i) ok[i] = describer.describe(corners0[i].x, corners0[i].y, &d0[i]);
  REQUIRE(describer.set_image(view_of(img1)));
  AllocScope scope;
  for (std::size_t i = 0; i < corners0.size(); ++i)
    ok[i] = ok[i] && describer.describe(corners1[i].x, corners1[i].y, &d1[i]);
  CHECK(scope.allocations() == 0);
  double same = 0.0, other = 0.0;
  int n_same = 0, n_other = 0;
  for (std::size_t i = 0; i < corners0.size(); ++i) {
    if (!ok[i]) continue;
    same += hamming(d0[i], d1[i]);
    ++n_same;
    const std::size_t j = (i + corners0.size() / 2) % corners0.size();
    if (ok[j]) {
      other += hamming(d0[i], d1[j]);
      ++n_other;
    }
  }
  REQUIRE(n_same > 50);
  INFO("mean Hamming distance: same corner " << same / n_same << ", other corner " << other / n_other);
  CHECK(same / n_same < 40.0);     // of 256 bits
  CHECK(other / n_other > 90.0);   // about half the bits for unrelated patches
}

TEST_CASE("BRIEF: a brightness offset changes no bit, the border is refused", "[loop]") {
  const cv::Mat img = load(micro_images()[10]);
  cv::Mat brighter;
  img.convertTo(brighter, CV_8UC1, 1.0, 20.0);
  cv::Mat mask = img < 230;  // where no pixel saturates
  BriefDescriber describer(752, 480);
  Descriptor a, b;
  REQUIRE(describer.set_image(view_of(img)));
  REQUIRE(describer.describe(376.0f, 240.0f, &a));
  CHECK_FALSE(describer.describe(5.0f, 240.0f, &a));
  CHECK_FALSE(describer.describe(376.0f, 479.0f - 10.0f, &a));
  REQUIRE(describer.describe(376.0f, 240.0f, &a));
  REQUIRE(describer.set_image(view_of(brighter)));
  REQUIRE(describer.describe(376.0f, 240.0f, &b));
  if (cv::countNonZero(mask(cv::Rect(376 - 20, 240 - 20, 41, 41))) == 41 * 41) CHECK(hamming(a, b) == 0);
  BriefDescriber small(100, 100);
  CHECK_FALSE(small.set_image(view_of(img)));  // larger than its capacity
}
