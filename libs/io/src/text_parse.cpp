#include "text_parse.hpp"

#include <cerrno>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <sstream>

#include "obm/core/errors.hpp"

namespace obm::io::detail {

std::string readWholeFile(const std::string& path) {
  std::error_code ec;
  if (std::filesystem::is_directory(path, ec))
    throw IoError("cannot read '" + path + "': it is a folder");
  std::ifstream is(path, std::ios::binary);
  if (!is) throw IoError("cannot open '" + path + "': " + std::strerror(errno));
  std::ostringstream ss;
  ss << is.rdbuf();
  if (is.bad()) throw IoError("cannot read '" + path + "': read error");
  return std::move(ss).str();
}

std::string toLower(std::string_view s) {
  std::string out(s);
  for (char& c : out)
    if (c >= 'A' && c <= 'Z') c = static_cast<char>(c - 'A' + 'a');
  return out;
}

std::string lowerExtension(const std::string& path) {
  std::string ext = std::filesystem::path(path).extension().string();
  if (!ext.empty() && ext.front() == '.') ext.erase(0, 1);
  return toLower(ext);
}

bool LineCursor::next(std::string_view& line) {
  if (pos_ >= text_.size()) return false;
  std::size_t end = pos_;
  while (end < text_.size() && text_[end] != '\n' && text_[end] != '\r') ++end;
  line = text_.substr(pos_, end - pos_);
  if (end < text_.size()) {
    // '\r\n' counts as one end-of-line.
    if (text_[end] == '\r' && end + 1 < text_.size() && text_[end + 1] == '\n') ++end;
    ++end;
  }
  pos_ = end;
  ++next_line_;
  return true;
}

namespace {
inline bool isBlank(char c) {
  return c == ' ' || c == '\t' || c == '\r' || c == '\n' || c == '\f' || c == '\v';
}
}  // namespace

std::string_view trim(std::string_view s) {
  while (!s.empty() && isBlank(s.front())) s.remove_prefix(1);
  while (!s.empty() && isBlank(s.back())) s.remove_suffix(1);
  return s;
}

void splitBlanks(std::string_view s, std::vector<std::string_view>& out) {
  out.clear();
  std::size_t i = 0;
  while (i < s.size()) {
    while (i < s.size() && isBlank(s[i])) ++i;
    const std::size_t b = i;
    while (i < s.size() && !isBlank(s[i])) ++i;
    if (i > b) out.push_back(s.substr(b, i - b));
  }
}

double parseDouble(std::string_view tok, const std::string& file, std::size_t line,
                   const std::string& what) {
  double v = 0.0;
  if (!parseNumber(tok, v))
    throw FormatError(file, line, what + ": '" + std::string(tok) + "' is not a number");
  return v;
}

long long parseInteger(std::string_view tok, const std::string& file, std::size_t line,
                       const std::string& what) {
  long long v = 0;
  if (!parseNumber(tok, v))
    throw FormatError(file, line, what + ": '" + std::string(tok) + "' is not an integer");
  return v;
}

}  // namespace obm::io::detail
