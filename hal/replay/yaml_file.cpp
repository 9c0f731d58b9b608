#include "hal/replay/yaml_file.hpp"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdlib>
#include <fstream>
#include <sstream>
#include <stdexcept>

#include <Eigen/SVD>
#include <opencv2/core.hpp>

namespace ums::hal {

namespace {

std::string format_number(double v) {
  std::ostringstream out;
  out.precision(12);
  out << v;
  return out.str();
}

std::string describe_node(const cv::FileNode& n) {
  if (n.isNone()) return "(empty)";
  if (n.isString()) return "'" + n.string() + "'";
  if (n.isInt()) return std::to_string(static_cast<int>(n));
  if (n.isReal()) return format_number(n.real());
  if (n.isSeq()) {
    std::string s = "[";
    for (std::size_t i = 0; i < n.size(); ++i) {
      if (i > 0) s += ", ";
      if (i == 8) { s += "..."; break; }
      s += describe_node(n[static_cast<int>(i)]);
    }
    return s + "]";
  }
  if (n.isMap()) return "(a map)";
  return "(unknown)";
}

bool is_number(const cv::FileNode& n) {
  return n.isInt() || (n.isReal() && std::isfinite(n.real()));
}

double to_number(const cv::FileNode& n) { return n.isInt() ? static_cast<double>(static_cast<int>(n)) : n.real(); }

}  // namespace

bool yaml_root_is_map(const std::string& text) {
  std::size_t at = 0;
  while (at < text.size()) {
    const std::size_t end = std::min(text.find('\n', at), text.size());
    const std::size_t first = text.find_first_not_of(" \t\r", at);
    const bool skip = first >= end || text[first] == '#' || text[first] == '%' ||
                      text.compare(first, 3, "---") == 0;
    if (!skip) {
      // A key: a plain or quoted scalar followed by ':' on this line; not a sequence or flow value.
      const char c = text[first];
      return c != '[' && c != '{' && c != '-' && text.find(':', first) < end;
    }
    at = end + 1;
  }
  return true;  // no content: OpenCV reads an empty document safely
}

std::size_t yaml_first_control_byte(const std::string& text) {
  for (std::size_t i = 0; i < text.size(); ++i) {
    const auto c = static_cast<unsigned char>(text[i]);
    if ((c < 0x20 && c != '\t' && c != '\n' && c != '\r') || c == 0x7F) return i;
  }
  return std::string::npos;
}

namespace {

// Flow-collection depth after one line (quotes and comments skipped); starts at `depth`.
int flow_depth_after(const std::string& text, std::size_t begin, std::size_t end, int depth) {
  char quote = 0;
  for (std::size_t i = begin; i < end; ++i) {
    const char c = text[i];
    if (quote != 0) {
      if (c == quote) quote = 0;
    } else if (c == '"' || c == '\'') {
      quote = c;
    } else if (c == '#' && (i == begin || text[i - 1] == ' ' || text[i - 1] == '\t')) {
      break;
    } else if (c == '[' || c == '{') {
      ++depth;
    } else if ((c == ']' || c == '}') && depth > 0) {
      --depth;
    }
  }
  return depth;
}

enum class LineKind { kOther, kItem, kKeyEmpty, kKeyValue };

bool key_char(char c) {
  return std::isalnum(static_cast<unsigned char>(c)) != 0 || c == '_' || c == '.' || c == '-' || c == '/';
}

// A content line at depth 0: "- item", or "key:" with a key the readers use (a name, or quoted),
// the ':' followed by a blank or the end of the line; anything else is kOther.
LineKind line_kind(const std::string& text, std::size_t first, std::size_t end) {
  if (text[first] == '-' && (first + 1 >= end || text[first + 1] == ' ' || text[first + 1] == '\r')) {
    return LineKind::kItem;
  }
  std::size_t i = first;
  if (text[i] == '"' || text[i] == '\'') {
    const std::size_t close = text.find(text[i], i + 1);
    if (close >= end) return LineKind::kOther;
    i = close + 1;
  } else {
    if (!(std::isalpha(static_cast<unsigned char>(text[i])) != 0 || text[i] == '_')) return LineKind::kOther;
    while (i < end && key_char(text[i])) ++i;
  }
  while (i < end && text[i] == ' ') ++i;
  if (i >= end || text[i] != ':') return LineKind::kOther;
  ++i;
  if (i < end && text[i] != ' ' && text[i] != '\t' && text[i] != '\r') return LineKind::kOther;
  const std::size_t rest = text.find_first_not_of(" \t\r", i);
  return rest >= end || text[rest] == '#' ? LineKind::kKeyEmpty : LineKind::kKeyValue;
}

// Every file read here is ASCII outside its comments (OpenCV 4.6 took over a second on a
// value of 70 0xBC bytes before a '[': sensor_yaml_fuzz).
bool non_ascii_before_comment(const std::string& text, std::size_t first, std::size_t end) {
  for (std::size_t i = first; i < end; ++i) {
    if (text[i] == '#' && (i == first || text[i - 1] == ' ' || text[i - 1] == '\t')) return false;
    if (static_cast<unsigned char>(text[i]) >= 0x80) return true;
  }
  return false;
}

// "---" or "..." alone on its line (a comment may follow). With content after it, the line is
// content (and refused as stray: OpenCV never returns on "...  - [0]" after a sequence).
bool document_marker(const std::string& text, std::size_t first, std::size_t end) {
  if (text.compare(first, 3, "---") != 0 && text.compare(first, 3, "...") != 0) return false;
  const std::size_t rest = text.find_first_not_of(" \t\r", first + 3);
  return rest >= end || text[rest] == '#';
}

// Walks the content lines: calls on_line(line number, first, end, depth at its start) and
// returns the line that opened a flow collection still open at the end (0: none). on_line
// returning false stops the walk (the result is then 0).
template <typename OnLine>
std::size_t walk_yaml_lines(const std::string& text, OnLine on_line) {
  int depth = 0;
  std::size_t line = 0, opened_at = 0;
  for (std::size_t at = 0; at < text.size();) {
    ++line;
    const std::size_t end = std::min(text.find('\n', at), text.size());
    const std::size_t first = text.find_first_not_of(" \t\r", at);
    const bool skip = first >= end || text[first] == '#' || text[first] == '%' || document_marker(text, first, end);
    if (!skip) {
      if (!on_line(line, first, end, depth)) return 0;
      if (depth == 0) opened_at = line;
      depth = flow_depth_after(text, first, end, depth);
    }
    at = end + 1;
  }
  return depth > 0 ? opened_at : 0;
}

}  // namespace

std::size_t yaml_first_stray_line(const std::string& text) {
  std::size_t stray = 0;
  LineKind previous = LineKind::kKeyEmpty;  // the root map's
  std::size_t previous_indent = 0, root_indent = std::string::npos;
  walk_yaml_lines(text, [&](std::size_t line, std::size_t first, std::size_t end, int depth) {
    if (non_ascii_before_comment(text, first, end)) {
      stray = line;
      return false;
    }
    if (depth > 0) return true;
    const std::size_t indent = first - (text.rfind('\n', first) == std::string::npos ? 0 : text.rfind('\n', first) + 1);
    if (root_indent == std::string::npos) root_indent = indent;
    const LineKind kind = line_kind(text, first, end);
    // An item continues its sequence at the same indentation, or starts one under a key without
    // a value (Kalibr puts it at the key's own indentation); nothing is left of the root.
    bool ok = kind != LineKind::kOther && indent >= root_indent;
    if (kind == LineKind::kItem) {
      ok = ok && ((previous == LineKind::kItem && indent == previous_indent) ||
                  (previous == LineKind::kKeyEmpty && indent >= previous_indent));
    }
    if (!ok) stray = line;
    previous = kind;
    previous_indent = indent;
    return ok;
  });
  return stray;
}

std::size_t yaml_unclosed_flow_line(const std::string& text) {
  return walk_yaml_lines(text, [](std::size_t, std::size_t, std::size_t, int) { return true; });
}

YamlFile::YamlFile(const std::string& path) : path_(path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw std::runtime_error(path + ": cannot open");
  std::ostringstream content;
  content << in.rdbuf();
  std::string text = content.str();
  if (!yaml_root_is_map(text)) throw std::runtime_error(path + ": expected a YAML map of keys");
  if (const std::size_t at = yaml_first_control_byte(text); at != std::string::npos) {
    throw std::runtime_error(path + ": byte " + std::to_string(at) + " is a control character, not YAML text");
  }
  if (const std::size_t line = yaml_first_stray_line(text); line != 0) {
    throw std::runtime_error(path + ":" + std::to_string(line) + ": expected \"key: value\" or \"- item\"");
  }
  if (const std::size_t line = yaml_unclosed_flow_line(text); line != 0) {
    throw std::runtime_error(path + ":" + std::to_string(line) + ": YAML syntax error: '[' or '{' never closed");
  }
  const bool add_directive = text.compare(0, 5, "%YAML") != 0;
  if (add_directive) text = "%YAML:1.0\n" + text;
  try {
    storage_.open(text, cv::FileStorage::READ | cv::FileStorage::MEMORY | cv::FileStorage::FORMAT_YAML);
  } catch (const cv::Exception& e) {
    // OpenCV puts "<name>(<line>): <problem>" into the function field of its parse errors.
    const std::string& where = e.func;
    const std::size_t open = where.rfind("(", where.find("): "));
    const std::size_t close = where.find("): ");
    if (open != std::string::npos && close != std::string::npos && close > open) {
      long line = std::strtol(where.c_str() + open + 1, nullptr, 10);
      if (add_directive) --line;
      throw std::runtime_error(path + ":" + std::to_string(line) + ": YAML syntax error: " +
                               where.substr(close + 3));
    }
    throw std::runtime_error(path + ": YAML syntax error: " + e.what());
  }
  if (!storage_.isOpened()) throw std::runtime_error(path + ": not a YAML file");
  if (!storage_.root().isMap()) throw std::runtime_error(path + ": expected a YAML map of keys");
}

namespace {

// "a.b" looks up key b inside map a (nested maps of camodocal files).
cv::FileNode lookup(const cv::FileStorage& storage, const std::string& key) {
  const std::size_t dot = key.find('.');
  if (dot == std::string::npos) return storage[key];
  const cv::FileNode parent = storage[key.substr(0, dot)];
  if (!parent.isMap()) return cv::FileNode();
  return parent[key.substr(dot + 1)];
}

}  // namespace

bool YamlFile::has(const std::string& key) const { return !lookup(storage_, key).empty(); }

std::vector<std::string> YamlFile::keys() const { return storage_.root().keys(); }

void YamlFile::fail(const std::string& key, const std::string& problem) const {
  throw std::runtime_error(path_ + ": key '" + key + "': " + problem);
}

std::string YamlFile::describe(const std::string& key) const { return describe_node(lookup(storage_, key)); }

cv::FileNode YamlFile::node(const std::string& key) const {
  cv::FileNode n = lookup(storage_, key);
  if (n.empty()) fail(key, "missing");
  return n;
}

double YamlFile::number(const std::string& key) const {
  const cv::FileNode n = node(key);
  if (!is_number(n)) fail(key, "expected a number, got " + describe_node(n));
  return to_number(n);
}

int YamlFile::integer(const std::string& key) const {
  const cv::FileNode n = node(key);
  if (n.isInt()) return static_cast<int>(n);
  if (n.isReal() && std::isfinite(n.real()) && n.real() == std::floor(n.real()) &&
      std::fabs(n.real()) < 2e9) {
    return static_cast<int>(n.real());
  }
  fail(key, "expected an integer, got " + describe_node(n));
}

std::string YamlFile::text(const std::string& key) const {
  const cv::FileNode n = node(key);
  if (!n.isString()) fail(key, "expected a string, got " + describe_node(n));
  return n.string();
}

std::vector<double> YamlFile::numbers(const std::string& key, std::size_t count) const {
  const cv::FileNode n = node(key);
  const std::string expected = "expected a list of " + std::to_string(count) + " numbers, got ";
  if (!n.isSeq() || n.size() != count) fail(key, expected + describe_node(n));
  std::vector<double> values(count);
  for (std::size_t i = 0; i < count; ++i) {
    const cv::FileNode e = n[static_cast<int>(i)];
    if (!is_number(e)) fail(key, expected + describe_node(n));
    values[i] = to_number(e);
  }
  return values;
}

std::vector<double> YamlFile::matrix(const std::string& key, int rows, int cols) const {
  const cv::FileNode n = node(key);
  const std::string expected = "expected a " + std::to_string(rows) + "x" + std::to_string(cols) +
                               " matrix {rows: " + std::to_string(rows) + ", cols: " +
                               std::to_string(cols) + ", data: [" + std::to_string(rows * cols) +
                               " numbers]}";
  if (!n.isMap()) fail(key, expected + ", got " + describe_node(n));
  const cv::FileNode r = n["rows"], c = n["cols"], d = n["data"];
  if (!r.isInt() || !c.isInt() || static_cast<int>(r) != rows || static_cast<int>(c) != cols) {
    fail(key, expected + ", got rows: " + describe_node(r) + ", cols: " + describe_node(c));
  }
  if (!d.isSeq() || d.size() != static_cast<std::size_t>(rows * cols)) {
    fail(key, expected + ", got data: " + describe_node(d) + " (" + std::to_string(d.size()) + " values)");
  }
  std::vector<double> values(static_cast<std::size_t>(rows * cols));
  for (std::size_t i = 0; i < values.size(); ++i) {
    const cv::FileNode e = d[static_cast<int>(i)];
    if (!is_number(e)) fail(key, "data[" + std::to_string(i) + "] is not a number: " + describe_node(e));
    values[i] = to_number(e);
  }
  return values;
}

Eigen::Isometry3d YamlFile::transform(const std::string& key) const {
  const std::vector<double> m = matrix(key, 4, 4);
  const Eigen::Matrix4d T = Eigen::Map<const Eigen::Matrix<double, 4, 4, Eigen::RowMajor>>(m.data());
  if (std::fabs(T(3, 0)) > 1e-9 || std::fabs(T(3, 1)) > 1e-9 || std::fabs(T(3, 2)) > 1e-9 ||
      std::fabs(T(3, 3) - 1.0) > 1e-9) {
    fail(key, "last row must be [0, 0, 0, 1]");
  }
  const Eigen::Matrix3d R = T.topLeftCorner<3, 3>();
  const double error = (R.transpose() * R - Eigen::Matrix3d::Identity()).norm();
  if (!(error < 1e-3) || R.determinant() < 0.0) {
    fail(key, "rotation part is not a rotation (|R^T R - I| = " + format_number(error) +
                  ", det = " + format_number(R.determinant()) + ")");
  }
  // Nearest rotation: removes the ~1e-6 non-orthogonality of printed calibrations.
  Eigen::JacobiSVD<Eigen::Matrix3d> svd(R, Eigen::ComputeFullU | Eigen::ComputeFullV);
  Eigen::Isometry3d out = Eigen::Isometry3d::Identity();
  out.linear() = svd.matrixU() * svd.matrixV().transpose();
  out.translation() = T.topRightCorner<3, 1>();
  return out;
}

}  // namespace ums::hal
