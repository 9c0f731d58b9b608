#include "profiling/json_writer.hpp"

#include <cinttypes>
#include <cmath>
#include <cstdio>
#include <cstdlib>

namespace ums {

void JsonWriter::newline() {
  if (indent_ <= 0) return;
  out_ += '\n';
  out_.append(static_cast<std::size_t>(depth_ * indent_), ' ');
}

void JsonWriter::open_item(const char* key) {
  if (!first_in_scope_) out_ += ',';
  if (depth_ > 0) newline();
  first_in_scope_ = false;
  if (key != nullptr) {
    append_escaped(&out_, key);
    out_ += indent_ > 0 ? ": " : ":";
  }
}

void JsonWriter::append_escaped(std::string* out, const char* s) {
  *out += '"';
  for (const char* c = s; *c != '\0'; ++c) {
    const unsigned char u = static_cast<unsigned char>(*c);
    switch (*c) {
      case '"': *out += "\\\""; break;
      case '\\': *out += "\\\\"; break;
      case '\n': *out += "\\n"; break;
      case '\r': *out += "\\r"; break;
      case '\t': *out += "\\t"; break;
      default:
        if (u < 0x20) {
          char buf[8];
          std::snprintf(buf, sizeof(buf), "\\u%04x", u);
          *out += buf;
        } else {
          *out += *c;
        }
    }
  }
  *out += '"';
}

JsonWriter& JsonWriter::begin_object(const char* key) {
  open_item(key);
  out_ += '{';
  ++depth_;
  first_in_scope_ = true;
  return *this;
}

JsonWriter& JsonWriter::end_object() {
  --depth_;
  if (!first_in_scope_) newline();
  out_ += '}';
  first_in_scope_ = false;
  if (depth_ == 0) out_ += '\n';
  return *this;
}

JsonWriter& JsonWriter::begin_array(const char* key) {
  open_item(key);
  out_ += '[';
  ++depth_;
  first_in_scope_ = true;
  return *this;
}

JsonWriter& JsonWriter::end_array() {
  --depth_;
  if (!first_in_scope_) newline();
  out_ += ']';
  first_in_scope_ = false;
  return *this;
}

JsonWriter& JsonWriter::value(const char* key, double v, int significant_digits) {
  open_item(key);
  if (!std::isfinite(v)) {
    out_ += "null";
    return *this;
  }
  // The shortest of 15, 16 or 17 significant digits that reads back exactly: 0.1 stays "0.1",
  // absolute timestamps in seconds keep their microseconds.
  char buf[40];
  if (significant_digits > 0) {
    std::snprintf(buf, sizeof(buf), "%.*g", significant_digits, v);
    out_ += buf;
    return *this;
  }
  for (int digits = 15; digits <= 17; ++digits) {
    std::snprintf(buf, sizeof(buf), "%.*g", digits, v);
    if (std::strtod(buf, nullptr) == v) break;
  }
  out_ += buf;
  return *this;
}

JsonWriter& JsonWriter::value(const char* key, std::int64_t v) {
  open_item(key);
  char buf[32];
  std::snprintf(buf, sizeof(buf), "%" PRId64, v);
  out_ += buf;
  return *this;
}

JsonWriter& JsonWriter::value(const char* key, std::uint64_t v) {
  open_item(key);
  char buf[32];
  std::snprintf(buf, sizeof(buf), "%" PRIu64, v);
  out_ += buf;
  return *this;
}

JsonWriter& JsonWriter::value(const char* key, bool v) {
  open_item(key);
  out_ += v ? "true" : "false";
  return *this;
}

JsonWriter& JsonWriter::value(const char* key, const char* v) {
  open_item(key);
  append_escaped(&out_, v);
  return *this;
}

JsonWriter& JsonWriter::null(const char* key) {
  open_item(key);
  out_ += "null";
  return *this;
}

}  // namespace ums
