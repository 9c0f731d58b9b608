#pragma once
// The place-recognition vocabulary built into the program (--loop): no file to find or download on
// the vehicle. Its bytes are board/host/vocabulary/sim_k10l4.voc, assembled into the binary;
// docs/loop-closure.md says what it was trained on and with which command.

#include <cstdint>
#include <vector>

namespace ums::cli {

inline constexpr const char* kBuiltinVocabularyName = "builtin:sim_k10l4";

std::vector<std::uint8_t> builtin_vocabulary_bytes();

}  // namespace ums::cli
