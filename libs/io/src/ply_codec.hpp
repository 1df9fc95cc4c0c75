#pragma once
// Internal: the PLY container (Turk's polygon file format, as documented by Paul Bourke):
// a text header of `element <name> <count>` blocks with `property <type> <name>` and
// `property list <count-type> <item-type> <name>` lines, then the body in ascii,
// binary_little_endian or binary_big_endian. The readers of meshes and point clouds use this to
// walk every element (unknown ones are skipped) and pick the properties they need.
#include <cstddef>
#include <cstdint>
#include <ostream>
#include <string>
#include <string_view>
#include <vector>

namespace obm::io::detail {

enum class PlyType { Int8, UInt8, Int16, UInt16, Int32, UInt32, Float32, Float64 };
enum class PlyEncoding { Ascii, BinaryLittleEndian, BinaryBigEndian };

/// Byte size of a PLY scalar type.
std::size_t plyTypeSize(PlyType t);
/// "uchar", "float", ... (the spec's original names, which every reader accepts).
const char* plyTypeName(PlyType t);

struct PlyProperty {
  std::string name;
  PlyType type = PlyType::Float32;  ///< scalar type, or item type of a list
  bool is_list = false;
  PlyType count_type = PlyType::UInt8;  ///< type of a list's leading count
};

struct PlyElement {
  std::string name;
  std::size_t count = 0;
  std::vector<PlyProperty> properties;
  std::size_t header_line = 0;  ///< line of its `element` declaration (1-based)

  /// Index of the property called `name` (case-insensitive), or -1.
  int find(std::string_view name) const;
};

struct PlyHeader {
  PlyEncoding encoding = PlyEncoding::Ascii;
  std::vector<PlyElement> elements;
  std::size_t body_offset = 0;        ///< byte offset of the first body byte
  std::size_t body_first_line = 0;    ///< line number of the first body line (ascii)
  std::vector<std::string> comments;  ///< text of the `comment` lines, without the keyword
};

/// Parses the header of `data` (the whole file); throws FormatError(file, line, ...) when it is
/// not a PLY header or a line is malformed.
PlyHeader parsePlyHeader(const std::string& file, std::string_view data);

/// Sequential reader of the body records.
class PlyBodyReader {
 public:
  PlyBodyReader(const std::string& file, std::string_view data, const PlyHeader& header);

  /// Reads record `index` (for messages) of element `el`. `values[p]` receives scalar property p
  /// (NaN for list properties); `lists[p]` the items of list property p. Both are resized to the
  /// number of properties. Throws FormatError when the body ends early or a value is malformed.
  void read(const PlyElement& el, std::size_t index, std::vector<double>& values,
            std::vector<std::vector<double>>& lists);

  /// Skips every record of `el`.
  void skip(const PlyElement& el);

  /// Current line (ascii) for messages; 0 for binary bodies.
  std::size_t line() const noexcept { return binary_ ? 0 : line_; }

 private:
  double readValue(PlyType t, const PlyElement& el, std::size_t index);
  std::string_view nextToken(const PlyElement& el, std::size_t index);

  const std::string& file_;
  std::string_view data_;
  std::size_t pos_;
  std::size_t line_;
  bool binary_;
  bool swap_;
};

/// Writes one scalar in binary with the requested byte order.
void writePlyBinary(std::ostream& os, PlyType t, double v, bool big_endian);

}  // namespace obm::io::detail
