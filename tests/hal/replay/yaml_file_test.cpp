#include "hal/replay/yaml_file.hpp"

#include <catch2/catch.hpp>
#include <fstream>
#include <sstream>

#include "tests/common/test_paths.hpp"

using ums::hal::YamlFile;

namespace {
std::string error_of(const YamlFile& y, void (*f)(const YamlFile&)) {
  try {
    f(y);
  } catch (const std::exception& e) {
    return e.what();
  }
  return "";
}
}  // namespace

TEST_CASE("YamlFile reads typed values and names file, key and value on errors", "[yaml]") {
  const std::string path = ums::test::make_temp_dir("yaml_file") + "/a.yaml";
  std::ofstream(path) << "%YAML:1.0\nreal: 1.5e-3 # comment\nint: 20\nfrac: 2.5\nname: pinhole\nword: abc\n"
                         "list: [1, 2.5, 3]\n"
                         "T: !!opencv-matrix\n   rows: 4\n   cols: 4\n   dt: d\n"
                         "   data: [0, -1, 0, 0.1, 1, 0, 0, 0.2, 0, 0, 1, 0.3, 0, 0, 0, 1]\n"
                         "Bad: {rows: 4, cols: 4, data: [2, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1]}\n";
  const YamlFile y(path);
  CHECK(y.number("real") == 1.5e-3);
  CHECK(y.number("int") == 20.0);
  CHECK(y.integer("int") == 20);
  CHECK(y.text("name") == "pinhole");
  CHECK(y.numbers("list", 3) == std::vector<double>{1, 2.5, 3});
  const Eigen::Isometry3d T = y.transform("T");
  CHECK(T.translation().z() == 0.3);
  CHECK(T.linear()(0, 1) == Approx(-1.0));
  CHECK(y.keys().size() == 8);
  CHECK(y.has("word"));
  CHECK_FALSE(y.has("nope"));

  CHECK_THAT(error_of(y, [](const YamlFile& f) { f.number("word"); }),
             Catch::Contains("a.yaml: key 'word': expected a number, got 'abc'"));
  CHECK_THAT(error_of(y, [](const YamlFile& f) { f.integer("frac"); }),
             Catch::Contains("key 'frac': expected an integer, got 2.5"));
  CHECK_THAT(error_of(y, [](const YamlFile& f) { f.numbers("list", 4); }),
             Catch::Contains("key 'list': expected a list of 4 numbers, got [1, 2.5, 3]"));
  CHECK_THAT(error_of(y, [](const YamlFile& f) { f.text("missing"); }), Catch::Contains("key 'missing': missing"));
  CHECK_THAT(error_of(y, [](const YamlFile& f) { f.matrix("T", 3, 3); }), Catch::Contains("key 'T': expected a 3x3 matrix"));
  CHECK_THAT(error_of(y, [](const YamlFile& f) { f.transform("Bad"); }), Catch::Contains("key 'Bad': rotation part is not a rotation"));
}

TEST_CASE("YamlFile syntax errors give the file's own line, with or without %YAML", "[yaml]") {
  const std::string dir = ums::test::make_temp_dir("yaml_syntax");
  std::ofstream(dir + "/with.yaml") << "%YAML:1.0\na: 1\nb: [1, 2\n";
  std::ofstream(dir + "/without.yaml") << "a: 1\nb: [1, 2\n";
  CHECK_THROWS_WITH(YamlFile(dir + "/with.yaml"), Catch::Contains("with.yaml:3: YAML syntax error"));
  CHECK_THROWS_WITH(YamlFile(dir + "/without.yaml"), Catch::Contains("without.yaml:2: YAML syntax error"));
  std::ofstream(dir + "/opencv.yaml") << "a: 1\nb: [1, 2]]\n";  // OpenCV's own message, its line
  CHECK_THROWS_WITH(YamlFile(dir + "/opencv.yaml"), Catch::Contains("opencv.yaml:2: YAML syntax error"));
  CHECK_THROWS_WITH(YamlFile(dir + "/absent.yaml"), Catch::Contains("absent.yaml: cannot open"));
}

// Found by tests/fuzz/kalibr_fuzz: OpenCV 4.6's parser never returns on this document (a root flow
// sequence followed by block items); the root is checked to be a map of keys before it parses.
TEST_CASE("YamlFile refuses a document whose root is not a map, without hanging OpenCV", "[yaml][fuzz]") {
  const std::string path = ums::test::make_temp_dir("yaml_file_root") + "/hang.yaml";
  std::ofstream(path) << "%YAML:1.0\n---\n[0]\n- [-1]\nc: p\n";
  CHECK_THROWS_WITH(YamlFile(path), path + ": expected a YAML map of keys");
  CHECK_FALSE(ums::hal::yaml_root_is_map("# c\n\n  - 1\n"));
  CHECK_FALSE(ums::hal::yaml_root_is_map("{a: 1}\n"));
  CHECK(ums::hal::yaml_root_is_map("%YAML:1.0\n---\n# c\n\"a b\": 1\n"));
  CHECK(ums::hal::yaml_root_is_map(""));
}

// Found by tests/fuzz/kalibr_fuzz (a timeout): OpenCV 4.6's parser never returns on this text with
// a form feed; control bytes are not YAML text and are refused first.
TEST_CASE("YamlFile refuses control characters, without hanging OpenCV", "[yaml][fuzz]") {
  const std::string path = ums::test::make_temp_dir("yaml_file_control") + "/hang.yaml";
  std::ofstream(path) << " T:a\nb: -\n\f";
  CHECK_THROWS_WITH(YamlFile(path), path + ": byte 10 is a control character, not YAML text");
  CHECK(ums::hal::yaml_first_control_byte("a: 1\t# c\r\n") == std::string::npos);
  CHECK(ums::hal::yaml_first_control_byte(std::string("a: \0", 4)) == 3);
}

// Found by tests/fuzz/kalibr_fuzz (a timeout): OpenCV 4.6's parser never returns on this plain
// ASCII text. Every file read here is "key:" lines, "- item" lines and flow collections, so a
// stray plain line is refused first, naming it; the shared files all pass.
TEST_CASE("YamlFile refuses a stray plain line, naming it, without hanging OpenCV", "[yaml][fuzz]") {
  const std::string path = ums::test::make_temp_dir("yaml_file_stray") + "/hang.yaml";
  std::ofstream(path) << "#\n u:[]\nx  -\ni";
  CHECK_THROWS_WITH(YamlFile(path), path + ":2: expected \"key: value\" or \"- item\"");  // "u:[]" 
  using ums::hal::yaml_first_stray_line;
  CHECK(yaml_first_stray_line("%YAML:1.0\n---\n# c\na: 1\nm: !!opencv-matrix\n   rows: 1\n   data: [1, 2,\n      3, 4]\n") == 0);
  CHECK(yaml_first_stray_line("T:\n- [1, 2]\n- [3]\ns: \"x ] y\" # ]\nc:\n  U:\n  - [4]\n  - [5]\n...\n") == 0);
  CHECK(yaml_first_stray_line("T:\n- [1]\n  - [2]\n") == 3);  // items of one sequence line up
  CHECK(yaml_first_stray_line("  T:\n  - [1]\n-\n") == 3);    // nothing left of the root (kalibr_fuzz)
  CHECK(yaml_first_stray_line("a: 1 # \xc2\xb5m\nb: \xbc\xbc[1]\n") == 2);  // ASCII outside comments
  CHECK(yaml_first_stray_line("a: [1,\n 2]\nb\n") == 3);
  CHECK(yaml_first_stray_line("a: \"[\"\nplain text\n") == 2);  // a bracket in quotes opens nothing
  CHECK(yaml_first_stray_line("a: 1 # [\nb c\n") == 2);        // nor one in a comment
  CHECK(yaml_first_stray_line("-x: 1\n") == 1);                 // no key the readers use
  CHECK(yaml_first_stray_line("a: 1\n- 2\n") == 2);            // an item under a key with a value
  CHECK(yaml_first_stray_line("a: 1\n1: 2\n") == 2);           // a number is no key here
  CHECK(yaml_first_stray_line("a:1\n") == 1);                   // ':' not followed by a blank
  // A document marker with content after it is content (kalibr_fuzz: OpenCV hangs on this).
  CHECK(yaml_first_stray_line("a:\n  - [1]\n...  - [0, 0]\n") == 3);
  CHECK(yaml_first_stray_line("--- # c\na: 1\n...\n") == 0);
  // A '[' never closed (kalibr_fuzz found a text OpenCV hangs on with one): its line.
  CHECK(ums::hal::yaml_unclosed_flow_line("a: 1\nb: [1,\n 2\n") == 2);
  CHECK(ums::hal::yaml_unclosed_flow_line("a: [1,\n 2]\nb: {c: [3]}\n") == 0);
  const std::string hang = ums::test::make_temp_dir("yaml_file_unclosed") + "/hang.yaml";
  std::ofstream(hang) << "cam0:\n  d: [0.1,\n  0.2\n";
  CHECK_THROWS_WITH(YamlFile(hang), hang + ":2: YAML syntax error: '[' or '{' never closed");
  // The fuzzer's own text is refused even earlier now: "!a'0:" is no key.
  std::ofstream(hang) << "!a'0:\n  T_cui:m_ma.]\n;  - [0.stortion_model: equidistant\n  intradta [222";
  CHECK_THROWS_WITH(YamlFile(hang), hang + ":1: expected \"key: value\" or \"- item\"");
  // Every YAML file the project ships or reads from ../shared passes.
  for (const std::string& f : {ums::test::euroc_micro_dir() + "/mav0/cam0/sensor.yaml",
                               ums::test::euroc_micro_dir() + "/mav0/imu0/sensor.yaml"}) {
    std::ifstream in(f);
    std::stringstream text;
    text << in.rdbuf();
    INFO(f);
    CHECK(yaml_first_stray_line(text.str()) == 0);
  }
}
