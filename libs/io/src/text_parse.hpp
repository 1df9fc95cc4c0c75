#pragma once
// Internal routines shared by the file-format readers of obm::io: whole-file loading, a line cursor
// that counts lines (for error messages), whitespace tokenising and locale-independent number
// parsing (std::from_chars, so a user locale with ',' decimals cannot change what is read).
#include <charconv>
#include <cstddef>
#include <cstdint>
#include <string>
#include <string_view>
#include <system_error>
#include <vector>

namespace obm::io::detail {

/// Reads the whole file in binary mode; throws IoError naming it when it cannot be read.
std::string readWholeFile(const std::string& path);

/// Lower-cased extension without the dot ("ply" for "a/b.PLY"); empty when there is none.
std::string lowerExtension(const std::string& path);

/// ASCII lower-casing.
std::string toLower(std::string_view s);

/// Iterates over the lines of an in-memory text ('\n', '\r\n' or '\r' endings).
class LineCursor {
 public:
  explicit LineCursor(std::string_view text, std::size_t offset = 0, std::size_t first_line = 1)
      : text_(text), pos_(offset), next_line_(first_line) {}

  /// Sets `line` to the next line (without its end-of-line) and returns true; false at the end.
  bool next(std::string_view& line);
  /// 1-based number of the line last returned by next().
  std::size_t lineNumber() const noexcept { return next_line_ - 1; }
  /// Byte offset just past the end-of-line of the line last returned.
  std::size_t offset() const noexcept { return pos_; }
  /// Bytes after offset().
  std::size_t remaining() const noexcept { return text_.size() - pos_; }

 private:
  std::string_view text_;
  std::size_t pos_;
  std::size_t next_line_;
};

/// Removes leading and trailing blanks (space, tab, CR, LF, FF, VT).
std::string_view trim(std::string_view s);

/// Splits on blanks; the views point into `s`.
void splitBlanks(std::string_view s, std::vector<std::string_view>& out);
inline std::vector<std::string_view> splitBlanks(std::string_view s) {
  std::vector<std::string_view> out;
  splitBlanks(s, out);
  return out;
}

/// Parses a whole token as a number (a leading '+' is accepted; "nan"/"inf" for floating types).
/// Returns false when the token is not entirely a number of type T.
template <typename T>
bool parseNumber(std::string_view tok, T& out) {
  if (!tok.empty() && tok.front() == '+') tok.remove_prefix(1);
  if (tok.empty()) return false;
  const char* end = tok.data() + tok.size();
  const auto r = std::from_chars(tok.data(), end, out);
  return r.ec == std::errc() && r.ptr == end;
}

/// Like parseNumber but throws FormatError(file, line, "<what>: '<tok>' is not a number").
double parseDouble(std::string_view tok, const std::string& file, std::size_t line,
                   const std::string& what);
long long parseInteger(std::string_view tok, const std::string& file, std::size_t line,
                       const std::string& what);

/// True when the host stores integers little-endian.
inline bool hostIsLittleEndian() noexcept {
  const std::uint16_t probe = 1;
  return *reinterpret_cast<const unsigned char*>(&probe) == 1;
}

}  // namespace obm::io::detail
