#pragma once
// Internal: the Object File Format (Geomview's OFF) header and vertex lines, shared by the mesh
// reader and the point-set reader. Keyword `[ST][C][N][4]OFF` (optional), then the counts
// `vertices faces [edges]`, then one vertex per line as `x y z [w] [nx ny nz] [r g b [a]] [s t]`.
// '#' starts a comment anywhere; blank lines are skipped.
#include <Eigen/Core>
#include <cstddef>
#include <string>
#include <string_view>
#include <vector>

#include "obm/core/point_cloud.hpp"
#include "text_parse.hpp"

namespace obm::io::detail {

struct OffHeader {
  bool homogeneous = false;  ///< '4' prefix: x y z w
  bool normals = false;      ///< 'N' prefix
  bool colors = false;       ///< 'C' prefix
  std::size_t num_vertices = 0;
  std::size_t num_faces = 0;
};

/// Next line with its comment removed that is not blank; false at the end of the text.
bool nextOffLine(LineCursor& cur, std::string_view& line);

/// Reads the keyword and the counts; throws FormatError(file, line, ...) when malformed. The counts
/// are not trusted for allocation: callers reserve at most offLinesCapacity() elements.
OffHeader parseOffHeader(LineCursor& cur, const std::string& file);

/// How many more lines of at least `min_chars` characters the rest of the text can hold: an upper
/// bound for reserving, so that a corrupt count cannot trigger a huge allocation.
inline std::size_t offLinesCapacity(const LineCursor& cur, std::size_t count,
                                    std::size_t min_chars) {
  const std::size_t cap = cur.remaining() / min_chars + 1;
  return count < cap ? count : cap;
}

/// Reads the line of vertex `v` (0-based). `color` is set when the header has the 'C' prefix and
/// the line carries a colour (integers 0-255 or floats 0-1); `has_color` tells whether it did.
void parseOffVertex(LineCursor& cur, const OffHeader& h, std::size_t v, const std::string& file,
                    std::vector<std::string_view>& tok, Eigen::Vector3f& p, Color3u8& color,
                    bool& has_color);

}  // namespace obm::io::detail
