// A vocabulary file (umsvins --vocabulary, vocab_command): Vocabulary::parse, then the lookups the
// loop closer makes with it. The trailing CRC-32 is made to match so the fuzzer gets past it to
// the tree (a corrupt file is otherwise refused by the CRC alone).
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <stdexcept>
#include <vector>

#include "core/loop/bow_vector.hpp"
#include "core/loop/vocabulary.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  std::vector<std::uint8_t> bytes(data, data + size);
  if (bytes.size() >= 28) {
    const std::uint32_t crc = ums::loop::crc32(bytes.data(), bytes.size() - 4);
    for (int i = 0; i < 4; ++i) bytes[bytes.size() - 4 + static_cast<std::size_t>(i)] = static_cast<std::uint8_t>(crc >> (8 * i));
  }
  try {
    const ums::loop::Vocabulary vocabulary = ums::loop::Vocabulary::parse(bytes, "fuzz.voc");
    ums::loop::Descriptor descriptors[4] = {};
    for (int i = 0; i < 4; ++i) {
      for (std::size_t w = 0; w < descriptors[i].size(); ++w) descriptors[i][w] = 0x9E3779B97F4A7C15ull * (i * 4 + w + 1);
    }
    for (const auto& d : descriptors) (void)vocabulary.word_of(d);
    ums::loop::BowVector bow;
    vocabulary.transform(descriptors, 4, &bow);
  } catch (const std::runtime_error&) {
  }
  return 0;
}
