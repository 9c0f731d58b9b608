#pragma once
// Start-up reading of YAML files through cv::FileStorage (OpenCV's "%YAML:1.0" dialect, as EuRoC
// sensor.yaml and VINS-Fusion configs are written), with type-checked getters whose errors name
// the file, the key and the offending value. Files without a %YAML directive (common in
// EuRoC-derived datasets) are accepted: cv::FileStorage refuses them, so the text is parsed with a
// directive added and line numbers are corrected back.
//
// Not for the hot path: cv::FileStorage and the messages allocate.

#include <string>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <opencv2/core/persistence.hpp>

namespace ums::hal {

// False when the document's first content (after the %YAML directive, "---", blank and comment
// lines) is not a "key:" line, i.e. its root cannot be the map of keys every reader here needs.
// Checked before cv::FileStorage sees the text: OpenCV 4.6's parser never returns on some such
// documents ("---\n[0]\n- [-1]\nc: p", found by tests/fuzz/kalibr_fuzz).
bool yaml_root_is_map(const std::string& text);

// The offset of the first control byte YAML does not allow in a document (C0 other than tab, LF,
// CR; and DEL), or std::string::npos. Also checked before cv::FileStorage parses: OpenCV 4.6
// never returns on " T:a\nb: -\n\f" (found by tests/fuzz/kalibr_fuzz).
std::size_t yaml_first_control_byte(const std::string& text);

// The 1-based number of the first content line outside the subset every reader here takes
// (EuRoC sensor.yaml, VINS-Fusion configs and camodocal files, Kalibr), or 0. Outside flow
// collections ([...], {...}, which may span lines) a content line is "key: ..." (a name or a
// quoted key, the ':' followed by a blank) or "- item" (lined up with its sequence, which starts
// under a key without a value), never left of the root's first key; every content line is ASCII
// outside its comments. Checked before cv::FileStorage parses: OpenCV 4.6 never returns on
// several texts outside it ("#\n u:[]\nx  -\ni", "...  - [0]" after a sequence, ...: found by
// tests/fuzz/kalibr_fuzz and sensor_yaml_fuzz).
std::size_t yaml_first_stray_line(const std::string& text);

// The 1-based number of the line that opened a flow collection ('[' or '{') still open at the
// end of the text, or 0. OpenCV 4.6 never returns on some such texts either (kalibr_fuzz).
std::size_t yaml_unclosed_flow_line(const std::string& text);

class YamlFile {
 public:
  // Throws std::runtime_error "<path>: cannot open (...)" or "<path>:<line>: YAML syntax error: ...".
  explicit YamlFile(const std::string& path);

  const std::string& path() const { return path_; }
  // Keys may name a value inside a top-level map as "map.key" (camodocal's
  // projection_parameters.fx).
  bool has(const std::string& key) const;
  std::vector<std::string> keys() const;  // top-level keys in file order

  // Getters throw std::runtime_error "<path>: key '<key>': <problem>" (missing key, wrong type).
  double number(const std::string& key) const;   // finite real or integer
  int integer(const std::string& key) const;     // integer (a real with a fraction is refused)
  std::string text(const std::string& key) const;  // string scalar
  std::vector<double> numbers(const std::string& key, std::size_t count) const;  // a flat list
  // A rows x cols matrix stored as a map {rows, cols, data: [...]} (EuRoC T_BS) or as an
  // !!opencv-matrix (VINS-Fusion body_T_cam0, which adds dt), row-major.
  std::vector<double> matrix(const std::string& key, int rows, int cols) const;
  // A 4x4 rigid transform: matrix() plus a check that the last row is [0 0 0 1] and the rotation
  // is orthonormal (|R^T R - I| < 1e-3; Kalibr output carries ~1e-6), re-orthonormalized.
  Eigen::Isometry3d transform(const std::string& key) const;

  // "<path>: key '<key>': <problem>" for callers that check values themselves.
  [[noreturn]] void fail(const std::string& key, const std::string& problem) const;

  // The value of a scalar as text for messages ("0.5", "abc", "[list]").
  std::string describe(const std::string& key) const;

 private:
  cv::FileNode node(const std::string& key) const;  // throws when missing

  std::string path_;
  cv::FileStorage storage_;
};

}  // namespace ums::hal
