#pragma once
// Scratch files for harnesses whose parser reads a path: one folder per process under /dev/shm
// (tmpfs: no disk I/O per execution), named once and reused, removed at exit.
#include <cstddef>
#include <cstdint>
#include <string>

namespace ums::fuzz {

// The process's scratch folder (created on first use), without a trailing '/'.
const std::string& scratch_dir();

// Writes size bytes to <scratch_dir>/<name> (replacing it; name may hold folders) and returns the full path. Aborts on a
// write error: a harness that cannot write its input would otherwise report nothing.
std::string write_file(const std::string& name, const std::uint8_t* data, std::size_t size);
std::string write_file(const std::string& name, const std::string& text);
// Copies the file at source (an absolute path, e.g. a fixture) to <scratch_dir>/<name>.
std::string copy_file(const std::string& source, const std::string& name);

// Splits data at the separator line "\n--\n" into at most max_parts parts (the last part keeps
// the rest), so one input can feed several files of one reader.
std::size_t split_parts(const std::uint8_t* data, std::size_t size, std::string* parts, std::size_t max_parts);

}  // namespace ums::fuzz
