// The vocabulary built into the program (--loop) is, byte for byte, the file in the repository
// that docs/loop-closure.md describes (k 10, 4 levels, 9546 words, checksum 294545f3), and it
// parses; a change to the file without the docs shows up here.
#include "board/host/builtin_vocabulary.hpp"

#include <catch2/catch.hpp>
#include <fstream>
#include <iterator>

#include "core/loop/vocabulary.hpp"

namespace ums::cli {

TEST_CASE("builtin vocabulary: the repository's file, parsed, as documented", "[loop]") {
  const std::vector<std::uint8_t> bytes = builtin_vocabulary_bytes();
  std::ifstream in(UMS_BUILTIN_VOCABULARY, std::ios::binary);
  REQUIRE(in);
  const std::vector<std::uint8_t> file((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  CHECK(bytes == file);
  const loop::Vocabulary v = loop::Vocabulary::parse(bytes, kBuiltinVocabularyName);
  CHECK(v.k() == 10);
  CHECK(v.levels() == 4);
  CHECK(v.words() == 9546);
  CHECK(v.checksum() == 0x294545f3u);
}

}  // namespace ums::cli
