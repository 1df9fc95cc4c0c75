#include "off_codec.hpp"

#include <algorithm>
#include <cmath>

#include "obm/core/errors.hpp"

namespace obm::io::detail {

bool nextOffLine(LineCursor& cur, std::string_view& line) {
  std::string_view raw;
  while (cur.next(raw)) {
    const std::size_t h = raw.find('#');
    line = trim(h == std::string_view::npos ? raw : raw.substr(0, h));
    if (!line.empty()) return true;
  }
  return false;
}

OffHeader parseOffHeader(LineCursor& cur, const std::string& file) {
  OffHeader h;
  std::string_view line;
  std::vector<std::string_view> tok;
  if (!nextOffLine(cur, line)) throw FormatError(file, 0, "empty file, expected an OFF header");
  splitBlanks(line, tok);
  long long probe = 0;
  if (parseNumber(tok[0], probe)) {
    // The keyword is optional in Geomview's spec: the first line then holds the counts.
    tok.insert(tok.begin(), std::string_view("OFF"));
  }
  const std::string kw(tok[0]);
  const std::size_t off_pos = kw.rfind("OFF");
  if (off_pos == std::string::npos || off_pos + 3 != kw.size())
    throw FormatError(file, cur.lineNumber(),
                      "not an OFF file: expected a keyword ending in 'OFF', found '" + kw + "'");
  for (char c : kw.substr(0, off_pos)) {
    if (c == 'n')
      throw FormatError(file, cur.lineNumber(), "nOFF (dimension other than 3) is not supported");
    if (c == '4') h.homogeneous = true;
    if (c == 'N') h.normals = true;
    if (c == 'C') h.colors = true;
    if (c != 'S' && c != 'T' && c != 'C' && c != 'N' && c != '4')
      throw FormatError(file, cur.lineNumber(), "unknown OFF keyword '" + kw + "'");
  }
  if (tok.size() > 1 && tok[1] == "BINARY")
    throw FormatError(file, cur.lineNumber(), "binary OFF is not supported (ascii only)");
  std::size_t first = 1;
  if (tok.size() == 1) {  // counts on the next data line
    if (!nextOffLine(cur, line))
      throw FormatError(file, cur.lineNumber(), "missing 'vertices faces edges' counts");
    splitBlanks(line, tok);
    first = 0;
  }
  long long nv = -1, nf = -1;
  if (tok.size() < first + 2 || !parseNumber(tok[first], nv) || !parseNumber(tok[first + 1], nf) ||
      nv < 0 || nf < 0)
    throw FormatError(file, cur.lineNumber(),
                      "expected the counts 'vertices faces [edges]' (non-negative integers)");
  h.num_vertices = static_cast<std::size_t>(nv);
  h.num_faces = static_cast<std::size_t>(nf);
  return h;
}

void parseOffVertex(LineCursor& cur, const OffHeader& h, std::size_t v, const std::string& file,
                    std::vector<std::string_view>& tok, Eigen::Vector3f& p, Color3u8& color,
                    bool& has_color) {
  std::string_view line;
  if (!nextOffLine(cur, line))
    throw FormatError(file, cur.lineNumber(),
                      "file ends after " + std::to_string(v) + " of " +
                          std::to_string(h.num_vertices) + " vertices");
  splitBlanks(line, tok);
  const std::size_t ncoords = h.homogeneous ? 4 : 3;
  if (tok.size() < ncoords)
    throw FormatError(
        file, cur.lineNumber(),
        "vertex " + std::to_string(v) + " needs " + std::to_string(ncoords) + " coordinates");
  double c[4] = {0, 0, 0, 1};
  for (std::size_t k = 0; k < ncoords; ++k)
    c[k] = parseDouble(tok[k], file, cur.lineNumber(), "vertex " + std::to_string(v));
  if (h.homogeneous) {
    if (c[3] == 0.0)
      throw FormatError(file, cur.lineNumber(), "vertex " + std::to_string(v) + " has w = 0");
    c[0] /= c[3], c[1] /= c[3], c[2] /= c[3];
  }
  p = Eigen::Vector3f(static_cast<float>(c[0]), static_cast<float>(c[1]), static_cast<float>(c[2]));
  has_color = false;
  const std::size_t ci = ncoords + (h.normals ? 3 : 0);
  if (h.colors && tok.size() >= ci + 3) {
    // Integer components are 0-255; components with a decimal point are 0-1 (Geomview's spec).
    bool is_float = false;
    for (std::size_t k = ci; k < ci + 3; ++k)
      if (tok[k].find_first_of(".eE") != std::string_view::npos) is_float = true;
    for (std::size_t k = 0; k < 3; ++k) {
      double x = parseDouble(tok[ci + k], file, cur.lineNumber(), "vertex " + std::to_string(v));
      if (is_float) x *= 255.0;
      color[static_cast<Eigen::Index>(k)] =
          static_cast<std::uint8_t>(std::clamp(std::lround(x), 0L, 255L));
    }
    has_color = true;
  }
}

}  // namespace obm::io::detail
