#include "hal/replay/euroc_groundtruth.hpp"

#include <cinttypes>
#include <cmath>

namespace ums::hal {

void EurocGroundtruthReader::open(const std::string& path) {
  csv_.open(path);
  previous_line_ = 0;
}

CsvReader::Result EurocGroundtruthReader::next(GroundTruthState* state) {
  const CsvReader::Result r = csv_.next();
  if (r != CsvReader::Result::kRow) return r;
  if (csv_.field_count() != 17) {
    return csv_.fail("expected 17 columns (t, p xyz, q wxyz, v xyz, b_w xyz, b_a xyz), found %zu",
                     csv_.field_count());
  }
  std::int64_t t = 0;
  if (!csv_.field_int64(0, &t)) return csv_.fail("timestamp '%s' is not an integer (ns)", csv_.field(0));
  double v[16];
  for (std::size_t i = 0; i < 16; ++i) {
    if (!csv_.field_double(i + 1, &v[i])) {
      return csv_.fail("column %zu ('%s') is not a finite number", i + 1, csv_.field(i + 1));
    }
  }
  if (previous_line_ > 0 && t <= previous_t_ns_) {
    return csv_.fail("timestamp %" PRId64 " is not after %" PRId64 " on line %ld (timestamps must increase)", t,
                     previous_t_ns_, previous_line_);
  }
  const Eigen::Quaterniond q(v[3], v[4], v[5], v[6]);  // file order w, x, y, z
  if (std::fabs(q.norm() - 1.0) > 1e-3) return csv_.fail("quaternion norm %.6f is not 1", q.norm());
  previous_t_ns_ = t;
  previous_line_ = csv_.line();
  state->t_ns = t;
  state->p_w_b = Eigen::Vector3d(v[0], v[1], v[2]);
  state->q_w_b = q.normalized();
  state->v_w_b = Eigen::Vector3d(v[7], v[8], v[9]);
  state->gyro_bias_rad_s = Eigen::Vector3d(v[10], v[11], v[12]);
  state->accel_bias_m_s2 = Eigen::Vector3d(v[13], v[14], v[15]);
  return r;
}

}  // namespace ums::hal
