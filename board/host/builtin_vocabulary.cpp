#include "board/host/builtin_vocabulary.hpp"

// The file's bytes in read-only data, between two symbols (the assembler reads the file at build
// time; CMake names it in UMS_BUILTIN_VOCABULARY and rebuilds this object when it changes).
asm(".section .rodata\n"
    ".balign 16\n"
    ".global ums_builtin_vocabulary_begin\n"
    "ums_builtin_vocabulary_begin:\n"
    ".incbin \"" UMS_BUILTIN_VOCABULARY "\"\n"
    ".global ums_builtin_vocabulary_end\n"
    "ums_builtin_vocabulary_end:\n"
    ".previous\n");

extern "C" const std::uint8_t ums_builtin_vocabulary_begin[];
extern "C" const std::uint8_t ums_builtin_vocabulary_end[];

namespace ums::cli {

std::vector<std::uint8_t> builtin_vocabulary_bytes() {
  return std::vector<std::uint8_t>(ums_builtin_vocabulary_begin, ums_builtin_vocabulary_end);
}

}  // namespace ums::cli
