#pragma once
// Minimal streaming JSON writer for stats.json and sweep.json: objects, arrays, numbers, strings,
// booleans, with correct commas and string escaping. Non-finite numbers are written as null (JSON
// has no NaN). Start-up/shutdown code only: it builds a std::string.

#include <cstdint>
#include <string>

namespace ums {

class JsonWriter {
 public:
  explicit JsonWriter(int indent = 2) : indent_(indent) {}

  JsonWriter& begin_object(const char* key = nullptr);
  JsonWriter& end_object();
  JsonWriter& begin_array(const char* key = nullptr);
  JsonWriter& end_array();

  // significant_digits = 0: the shortest text that reads back exactly; else that many digits
  // (for measured times, where 17 digits would only print noise).
  JsonWriter& value(const char* key, double v, int significant_digits = 0);
  JsonWriter& value(const char* key, std::int64_t v);
  JsonWriter& value(const char* key, std::uint64_t v);
  JsonWriter& value(const char* key, int v) { return value(key, static_cast<std::int64_t>(v)); }
  JsonWriter& value(const char* key, bool v);
  JsonWriter& value(const char* key, const char* v);
  JsonWriter& value(const char* key, const std::string& v) { return value(key, v.c_str()); }
  JsonWriter& null(const char* key);

  // Array elements.
  JsonWriter& element(double v) { return value(nullptr, v); }
  JsonWriter& element(const char* v) { return value(nullptr, v); }

  const std::string& str() const { return out_; }

 private:
  void open_item(const char* key);
  void newline();
  static void append_escaped(std::string* out, const char* s);

  std::string out_;
  int indent_;
  int depth_ = 0;
  bool first_in_scope_ = true;
};

}  // namespace ums
