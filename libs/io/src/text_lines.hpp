#pragma once
// Internal helpers shared by the text-format readers of the dataset files (KITTI, TUM, Redwood,
// TUM RGB-D lists): line-by-line reading with 1-based line numbers, whitespace tokenising and
// locale-independent number parsing that reports the file and line of a bad field.
#include <charconv>
#include <cstdio>
#include <fstream>
#include <string>
#include <string_view>
#include <system_error>
#include <vector>

#include "obm/core/errors.hpp"

namespace obm::io::txt {

/// Reads a text file line by line; throws IoError naming the file when it cannot be opened.
class LineReader {
 public:
  explicit LineReader(const std::string& path) : path_(path), is_(path) {
    if (!is_) throw IoError("cannot open '" + path + "' for reading");
  }
  /// Next line without the trailing '\r' (Windows line ends); false at the end of the file.
  bool next(std::string& line) {
    if (!std::getline(is_, line)) {
      if (is_.bad()) throw IoError("read error in '" + path_ + "'");
      return false;
    }
    ++line_no_;
    if (!line.empty() && line.back() == '\r') line.pop_back();
    return true;
  }
  std::size_t lineNumber() const { return line_no_; }
  const std::string& path() const { return path_; }

 private:
  std::string path_;
  std::ifstream is_;
  std::size_t line_no_ = 0;
};

inline bool isSpace(char c) {
  return c == ' ' || c == '\t' || c == '\r' || c == '\n' || c == '\v';
}

/// True for an empty line or one holding only whitespace.
inline bool isBlank(std::string_view s) {
  for (char c : s)
    if (!isSpace(c)) return false;
  return true;
}

/// The line without leading whitespace.
inline std::string_view trimLeft(std::string_view s) {
  std::size_t i = 0;
  while (i < s.size() && isSpace(s[i])) ++i;
  return s.substr(i);
}

/// Splits on runs of whitespace (and, when `comma_is_space`, on commas too).
inline std::vector<std::string_view> tokenize(std::string_view s, bool comma_is_space = false) {
  std::vector<std::string_view> out;
  std::size_t i = 0;
  const auto sep = [&](char c) { return isSpace(c) || (comma_is_space && c == ','); };
  while (i < s.size()) {
    while (i < s.size() && sep(s[i])) ++i;
    const std::size_t b = i;
    while (i < s.size() && !sep(s[i])) ++i;
    if (i > b) out.push_back(s.substr(b, i - b));
  }
  return out;
}

/// Parses a whole token as a double (C locale, independent of the process locale). Throws
/// FormatError(file, line, ...) naming the field when it is not a number.
inline double parseDouble(std::string_view tok, const std::string& file, std::size_t line,
                          const char* field) {
  double v = 0.0;
  const char* b = tok.data();
  const char* e = tok.data() + tok.size();
  if (b != e && *b == '+')
    ++b;  // from_chars rejects a leading '+', which printf-style writers emit
  const auto r = std::from_chars(b, e, v);
  if (r.ec == std::errc::result_out_of_range) {
    // Denormal values (e.g. 1e-320) are out of range for from_chars but harmless: fall back.
    v = std::strtod(std::string(tok).c_str(), nullptr);
  } else if (r.ec != std::errc() || r.ptr != e) {
    throw FormatError(
        file, line,
        std::string("expected a number for ") + field + ", got '" + std::string(tok) + "'");
  }
  return v;
}

/// Parses a whole token as a (possibly negative) integer; FormatError otherwise.
inline long long parseInt(std::string_view tok, const std::string& file, std::size_t line,
                          const char* field) {
  long long v = 0;
  const char* b = tok.data();
  const char* e = tok.data() + tok.size();
  if (b != e && *b == '+') ++b;
  const auto r = std::from_chars(b, e, v);
  if (r.ec != std::errc() || r.ptr != e)
    throw FormatError(
        file, line,
        std::string("expected an integer for ") + field + ", got '" + std::string(tok) + "'");
  return v;
}

/// The shortest text that reads back to exactly the same double (C++17 `to_chars` round-trip
/// guarantee), e.g. "1", "0.1", "-2.5e-07".
inline std::string formatExact(double v) {
  char buf[64];
  const auto r = std::to_chars(buf, buf + sizeof(buf), v);
  return std::string(buf, r.ptr);
}

}  // namespace obm::io::txt
