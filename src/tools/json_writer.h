// A minimal streaming JSON writer for the command-line tool (inspect --json, eval --json, glTF).
// Commas and indentation are managed here so that callers cannot produce invalid JSON by
// forgetting one; non-finite numbers become null because JSON has no NaN or Infinity.
#pragma once

#include <cstdint>
#include <string>
#include <string_view>
#include <vector>

namespace cadinterp::cli {

class JsonWriter {
 public:
  /// Appends to `out`. indent 0: compact (one line), else that many spaces per level.
  explicit JsonWriter(std::string& out, int indent = 2) : out_(out), indent_(indent) {}

  JsonWriter& begin_object();
  JsonWriter& end_object();
  JsonWriter& begin_array();
  JsonWriter& end_array();
  /// The key of the next value; only inside an object.
  JsonWriter& key(std::string_view k);

  JsonWriter& value(std::string_view s);
  JsonWriter& value(const char* s) { return s ? value(std::string_view(s)) : null(); }
  JsonWriter& value(const std::string& s) { return value(std::string_view(s)); }
  JsonWriter& value(double v);
  /// Writes a float so that parsing the text gives back exactly that float (glTF min/max).
  JsonWriter& value_float(float v);
  JsonWriter& value(std::int64_t v);
  JsonWriter& value(std::uint64_t v);
  JsonWriter& value(int v) { return value(static_cast<std::int64_t>(v)); }
  JsonWriter& value(unsigned v) { return value(static_cast<std::uint64_t>(v)); }
  JsonWriter& value(bool v);
  JsonWriter& null();

  template <typename T>
  JsonWriter& field(std::string_view k, const T& v) {
    key(k);
    return value(v);
  }

  /// Quotes and escapes `s` as a JSON string (control characters as \u00XX; bytes >= 0x80 are
  /// passed through, so UTF-8 input stays UTF-8).
  static void append_string(std::string& out, std::string_view s);

 private:
  void before_value();
  void newline();

  std::string& out_;
  int indent_;
  struct Level {
    bool object;
    bool empty;
  };
  std::vector<Level> stack_;
  bool after_key_ = false;
};

}  // namespace cadinterp::cli
