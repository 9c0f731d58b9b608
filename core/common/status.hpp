#pragma once
// Status values for expected failures on the hot path (no exceptions there). Start-up code may
// throw with a message naming file, key and value; per-frame code returns one of these.

#include <cstdint>

namespace ums {

enum class Status : std::uint8_t {
  kOk = 0,
  kFull,            // a bounded buffer or pool is full; the caller decides what to drop and counts it
  kEmpty,           // nothing to pop or read
  kEndOfStream,     // a source has no more data
  kInvalidInput,    // NaN/Inf, out-of-order timestamp, wrong size
  kNotEnoughData,   // too few samples/features for the requested estimate
  kSingular,        // a linear system or block could not be factorized
  kNotConverged,    // an iterative method stopped on its iteration or time bound
  kIoError,         // a file or device could not be read or written
  kTimeout,         // a device did not deliver in time
  kUnsupported,     // a capability that does not exist (yet) or a format a device refuses
};

constexpr const char* to_string(Status s) {
  switch (s) {
    case Status::kOk: return "ok";
    case Status::kFull: return "full";
    case Status::kEmpty: return "empty";
    case Status::kEndOfStream: return "end of stream";
    case Status::kInvalidInput: return "invalid input";
    case Status::kNotEnoughData: return "not enough data";
    case Status::kSingular: return "singular";
    case Status::kNotConverged: return "not converged";
    case Status::kIoError: return "i/o error";
    case Status::kTimeout: return "timeout";
    case Status::kUnsupported: return "unsupported";
  }
  return "unknown";
}

}  // namespace ums
