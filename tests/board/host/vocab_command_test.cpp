// umsvins vocab train: a vocabulary from the micro sequence that core/loop reads back, and clear
// refusals of bad options and missing data.
#include "board/host/commands.hpp"

#include <catch2/catch.hpp>
#include <fstream>
#include <iterator>
#include <sstream>

#include "core/loop/vocabulary.hpp"
#include "tests/common/test_paths.hpp"

namespace ums::cli {
namespace {

int run(const std::vector<std::string>& args, std::string* out, std::string* err) {
  std::ostringstream o, e;
  const int code = run_cli(args, o, e);
  *out = o.str();
  *err = e.str();
  return code;
}

}  // namespace

TEST_CASE("umsvins vocab train writes a vocabulary that parses, and says what it was trained on", "[cli][loop]") {
  const std::string path = test::make_temp_dir("vocab_train") + "/micro.voc";
  std::string out, err;
  REQUIRE(run({"vocab", "train", test::euroc_micro_dir(), "--out", path, "--k", "6", "--levels", "3", "--every", "10"},
              &out, &err) == kExitOk);
  INFO(out << err);
  CHECK(out.find("10 of 95 left images") != std::string::npos);
  std::ifstream f(path, std::ios::binary);
  const std::vector<std::uint8_t> bytes((std::istreambuf_iterator<char>(f)), std::istreambuf_iterator<char>());
  const loop::Vocabulary voc = loop::Vocabulary::parse(bytes, path);
  CHECK(voc.k() == 6);
  CHECK(voc.levels() == 3);
  CHECK(voc.words() > 100);  // 10 images x up to 300 corners over at most 216 leaves
  char crc[16];
  std::snprintf(crc, sizeof(crc), "%08x", voc.checksum());
  CHECK(out.find(crc) != std::string::npos);
}

TEST_CASE("umsvins vocab: bad subcommands, options and datasets are refused with the reason", "[cli][loop]") {
  std::string out, err;
  CHECK(run({"vocab", "grow"}, &out, &err) == kExitUsage);
  CHECK(err.find("train") != std::string::npos);
  CHECK(run({"vocab", "train", test::euroc_micro_dir(), "--out", "/tmp/x.voc", "--levels", "9"}, &out, &err) == kExitUsage);
  CHECK(err.find("levels") != std::string::npos);
  CHECK(run({"vocab", "train", "/nonexistent", "--out", "/tmp/x.voc"}, &out, &err) == kExitFailure);
  CHECK(err.find("/nonexistent/mav0/cam0/data") != std::string::npos);
}

}  // namespace ums::cli
