#pragma once
// Test-only access to the EuRoC V1_01 micro sequence: the calibration (numbers copied from
// ../shared/data/euroc/V1_01_easy_micro/mav0/cam0/sensor.yaml and cam1/sensor.yaml; the dataset
// reader will provide them later) and all stereo pairs decoded into memory up front, so that the
// frame loop under test touches no file and no heap.

#include <fstream>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

#include "core/common/calibration.hpp"
#include "core/common/stereo_frame.hpp"
#include "hal/replay/png_io.hpp"
#include "tests/common/test_paths.hpp"

namespace ums::test {

inline RigCalibration euroc_rig() {
  RigCalibration rig;
  CameraCalibration& c0 = rig.cam[0];
  c0.model = CameraModel::kPinholeRadTan;
  c0.width = 752;
  c0.height = 480;
  c0.rate_hz = 20.0;
  c0.fx = 458.654;
  c0.fy = 457.296;
  c0.cx = 367.215;
  c0.cy = 248.375;
  c0.distortion = {-0.28340811, 0.07395907, 0.00019359, 1.76187114e-05};
  Eigen::Matrix4d T0;
  T0 << 0.0148655429818, -0.999880929698, 0.00414029679422, -0.0216401454975,  //
      0.999557249008, 0.0149672133247, 0.025715529948, -0.064676986768,        //
      -0.0257744366974, 0.00375618835797, 0.999660727178, 0.00981073058949,    //
      0.0, 0.0, 0.0, 1.0;
  c0.T_b_c.matrix() = T0;
  CameraCalibration& c1 = rig.cam[1];
  c1 = c0;
  c1.fx = 457.587;
  c1.fy = 456.134;
  c1.cx = 379.999;
  c1.cy = 255.238;
  c1.distortion = {-0.28368365, 0.07451284, -0.00010473, -3.55590700e-05};
  Eigen::Matrix4d T1;
  T1 << 0.0125552670891, -0.999755099723, 0.0182237714554, -0.0198435579556,  //
      0.999598781151, 0.0130119051815, 0.0251588363115, 0.0453689425024,      //
      -0.0253898008918, 0.0179005838253, 0.999517347078, 0.00786212447038,    //
      0.0, 0.0, 0.0, 1.0;
  c1.T_b_c.matrix() = T1;
  return rig;
}

struct EurocPairs {
  int width = 752, height = 480;
  std::vector<std::int64_t> t_ns;
  std::vector<std::vector<std::uint8_t>> left, right;

  std::size_t size() const { return t_ns.size(); }
  StereoFrame frame(std::size_t i) const {
    StereoFrame f;
    f.t_ns = t_ns[i];
    f.seq = i;
    f.left = ImageView{left[i].data(), width, height, width};
    f.right = ImageView{right[i].data(), width, height, width};
    return f;
  }
};

// Loads up to max_pairs pairs listed in cam0/data.csv whose cam0 and cam1 PNGs both exist.
inline EurocPairs load_euroc_micro(std::size_t max_pairs = 1000) {
  const std::string mav = euroc_micro_dir() + "/mav0";
  std::ifstream csv(mav + "/cam0/data.csv");
  if (!csv) throw std::runtime_error("cannot open " + mav + "/cam0/data.csv");
  EurocPairs out;
  std::string line;
  while (std::getline(csv, line) && out.size() < max_pairs) {
    if (line.empty() || line[0] == '#') continue;
    const std::size_t comma = line.find(',');
    if (comma == std::string::npos) continue;
    std::string name = line.substr(comma + 1);
    while (!name.empty() && (name.back() == '\r' || name.back() == ' ')) name.pop_back();
    std::vector<std::uint8_t> l(752 * 480), r(752 * 480);
    int w = 0, h = 0;
    std::string err;
    if (!hal::read_png_gray8(mav + "/cam0/data/" + name, l.data(), l.size(), &w, &h, &err) || w != 752 || h != 480) continue;
    if (!hal::read_png_gray8(mav + "/cam1/data/" + name, r.data(), r.size(), &w, &h, &err) || w != 752 || h != 480) continue;
    out.t_ns.push_back(std::stoll(line.substr(0, comma)));
    out.left.push_back(std::move(l));
    out.right.push_back(std::move(r));
  }
  return out;
}

}  // namespace ums::test
