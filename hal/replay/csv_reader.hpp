#pragma once
// Streaming reader for the comma-separated files of the EuRoC layout. One row at a time through a
// fixed buffer allocated once by the constructor, so a sequence of any length is read in bounded
// memory and the per-row path allocates nothing. Tolerates CRLF line ends, a UTF-8 byte-order
// mark, blank lines and lines starting with '#' (EuRoC's header rows).

#include <cstddef>
#include <cstdint>
#include <memory>
#include <string>

namespace ums::hal {

class CsvReader {
 public:
  static constexpr std::size_t kMaxFields = 32;          // columns per row
  static constexpr std::size_t kBufferBytes = 64 * 1024;  // bytes; also the longest accepted line
  static constexpr std::size_t kMaxPathBytes = 1024;      // bytes kept for messages

  enum class Result { kRow, kEnd, kError };

  CsvReader();
  ~CsvReader();
  CsvReader(const CsvReader&) = delete;
  CsvReader& operator=(const CsvReader&) = delete;

  // Start-up: opens path (closing any previous file). Throws std::runtime_error
  // "<path>: cannot open (<reason>)".
  void open(const std::string& path);
  void close();
  bool is_open() const { return fd_ >= 0; }

  // Reads the next data row. kError leaves the reason in error() ("<path>:<line>: ...").
  Result next();

  std::size_t field_count() const { return field_count_; }
  const char* field(std::size_t i) const { return fields_[i]; }  // NUL-terminated, trimmed
  long line() const { return line_; }                           // 1-based line of the current row
  const char* path() const { return path_; }
  const char* error() const { return error_; }

  // Field parsers: whole field must be a number (no trailing text). Locale-independent.
  bool field_int64(std::size_t i, std::int64_t* value) const;
  bool field_double(std::size_t i, double* value) const;  // also rejects NaN and Inf

  // Writes "<path>:<line>: <printf message>" into error() and returns kError.
  Result fail(const char* format, ...) __attribute__((format(printf, 2, 3)));

 private:
  bool fill();  // reads more bytes after the unconsumed tail; false at end of file or on error

  std::unique_ptr<char[]> buffer_;
  std::size_t begin_ = 0;  // first unconsumed byte
  std::size_t end_ = 0;    // one past the last valid byte
  bool eof_ = false;
  bool at_start_ = true;   // for the byte-order mark
  int fd_ = -1;
  long line_ = 0;
  std::size_t field_count_ = 0;
  char* fields_[kMaxFields] = {};
  char path_[kMaxPathBytes] = {};
  char error_[kMaxPathBytes + 256] = {};
};

}  // namespace ums::hal
