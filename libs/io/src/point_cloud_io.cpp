#include "obm/io/point_cloud_io.hpp"

#include <algorithm>
#include <charconv>
#include <climits>
#include <cmath>
#include <cstring>
#include <ostream>

#include "obm/core/atomic_file.hpp"
#include "obm/core/errors.hpp"
#include "obm/core/log.hpp"
#include "off_codec.hpp"
#include "ply_codec.hpp"
#include "text_parse.hpp"

namespace obm::io {
namespace {

using detail::LineCursor;
using detail::parseNumber;
using detail::PlyType;
using detail::splitBlanks;
using detail::trim;

constexpr const char* kLog = "io";
constexpr std::string_view kTimestampKey = "obm_timestamp";
constexpr std::string_view kFrameKey = "obm_frame_id";

/// Records the number of points read and drops the non-finite ones.
void finishRead(PointCloudReadResult& r) {
  r.num_in_file = r.cloud.size();
  r.num_nonfinite_dropped = r.cloud.removeNonFinite();
}

/// Reads an `obm_timestamp <t>` / `obm_frame_id <name>` comment into the cloud; ignores others.
void applyComment(std::string_view text, PointCloud& cloud) {
  text = trim(text);
  if (text.substr(0, kTimestampKey.size()) == kTimestampKey) {
    double t = 0;
    if (parseNumber(trim(text.substr(kTimestampKey.size())), t)) cloud.timestamp = t;
  } else if (text.substr(0, kFrameKey.size()) == kFrameKey) {
    const auto name = trim(text.substr(kFrameKey.size()));
    if (!name.empty()) cloud.frame_id = std::string(name);
  }
}

void appendNumber(std::string& out, float v) {
  char buf[32];
  const auto r = std::to_chars(buf, buf + sizeof buf, v);  // shortest text that reads back exactly
  out.append(buf, r.ptr);
}
void appendNumber(std::string& out, double v) {
  char buf[32];
  const auto r = std::to_chars(buf, buf + sizeof buf, v);
  out.append(buf, r.ptr);
}
void appendNumber(std::string& out, unsigned long v) {
  char buf[24];
  const auto r = std::to_chars(buf, buf + sizeof buf, v);
  out.append(buf, r.ptr);
}

/// Appends the `n` bytes of `v` in the requested byte order.
template <typename T>
void appendBinary(std::string& out, T v, bool big_endian) {
  unsigned char b[sizeof(T)];
  std::memcpy(b, &v, sizeof(T));
  if (big_endian == detail::hostIsLittleEndian()) std::reverse(b, b + sizeof(T));
  out.append(reinterpret_cast<const char*>(b), sizeof(T));
}

/// Indices of the finite points, and how many were not.
std::vector<std::size_t> finiteIndices(const PointCloud& cloud, std::size_t& dropped) {
  std::vector<std::size_t> idx;
  idx.reserve(cloud.size());
  for (std::size_t i = 0; i < cloud.size(); ++i)
    if (cloud.points[i].allFinite()) idx.push_back(i);
  dropped = cloud.size() - idx.size();
  return idx;
}

std::uint8_t colorByte(double v, PlyType t) {
  switch (t) {
    case PlyType::Float32:
    case PlyType::Float64:
      v *= 255.0;  // floating-point colours are 0-1
      break;
    case PlyType::UInt16:
    case PlyType::Int16:
      v /= 257.0;  // 0-65535 → 0-255
      break;
    default:
      break;
  }
  if (!(v > 0)) return 0;  // also NaN
  return static_cast<std::uint8_t>(std::min(255L, std::lround(v)));
}

}  // namespace

// ----------------------------------------------------------------------------------------------
// PLY

PointCloudReadResult parsePlyPointCloud(std::string_view data, const std::string& file) {
  const detail::PlyHeader h = detail::parsePlyHeader(file, data);
  detail::PlyBodyReader body(file, data, h);
  PointCloudReadResult r;
  for (const auto& c : h.comments) applyComment(c, r.cloud);
  bool have_vertices = false;
  std::vector<double> values;
  std::vector<std::vector<double>> lists;
  for (const auto& el : h.elements) {
    if (el.name != "vertex" || have_vertices) {
      body.skip(el);
      continue;
    }
    have_vertices = true;
    const int ix = el.find("x"), iy = el.find("y"), iz = el.find("z");
    if (ix < 0 || iy < 0 || iz < 0)
      throw FormatError(file, el.header_line, "element 'vertex' has no x, y and z properties");
    int ii = el.find("intensity");
    if (ii < 0) ii = el.find("scalar_intensity");
    int ic[3] = {el.find("red"), el.find("green"), el.find("blue")};
    if (ic[0] < 0 || ic[1] < 0 || ic[2] < 0)
      ic[0] = el.find("r"), ic[1] = el.find("g"), ic[2] = el.find("b");
    if (ic[0] < 0 || ic[1] < 0 || ic[2] < 0)
      ic[0] = el.find("diffuse_red"), ic[1] = el.find("diffuse_green"),
      ic[2] = el.find("diffuse_blue");
    const bool with_color = ic[0] >= 0 && ic[1] >= 0 && ic[2] >= 0;
    for (int i : {ix, iy, iz, ii, ic[0], ic[1], ic[2]})
      if (i >= 0 && el.properties[static_cast<std::size_t>(i)].is_list)
        throw FormatError(file, el.header_line,
                          "vertex property '" + el.properties[static_cast<std::size_t>(i)].name +
                              "' must be a scalar, not a list");
    auto& cloud = r.cloud;
    cloud.points.resize(el.count);
    if (ii >= 0) cloud.intensity.resize(el.count);
    if (with_color) cloud.colors.resize(el.count);
    const auto at = [&values](int i) { return values[static_cast<std::size_t>(i)]; };
    for (std::size_t i = 0; i < el.count; ++i) {
      body.read(el, i, values, lists);
      cloud.points[i] = Vector3f(static_cast<float>(at(ix)), static_cast<float>(at(iy)),
                                 static_cast<float>(at(iz)));
      if (ii >= 0) cloud.intensity[i] = static_cast<float>(at(ii));
      if (with_color)
        for (int k = 0; k < 3; ++k)
          cloud.colors[i][k] =
              colorByte(at(ic[k]), el.properties[static_cast<std::size_t>(ic[k])].type);
    }
  }
  if (!have_vertices) throw FormatError(file, 0, "PLY file has no 'vertex' element");
  finishRead(r);
  return r;
}

PointCloudReadResult readPlyPointCloud(const std::string& path) {
  return parsePlyPointCloud(detail::readWholeFile(path), path);
}

PointCloudWriteResult writePly(const std::string& path, const PointCloud& cloud, PlyFormat format) {
  cloud.validate();
  PointCloudWriteResult res;
  const auto idx = finiteIndices(cloud, res.num_nonfinite_dropped);
  res.num_written = idx.size();
  std::string out;
  out += "ply\nformat ";
  out += format == PlyFormat::Ascii                ? "ascii"
         : format == PlyFormat::BinaryLittleEndian ? "binary_little_endian"
                                                   : "binary_big_endian";
  out += " 1.0\ncomment ";
  out += kTimestampKey;
  out += ' ';
  appendNumber(out, cloud.timestamp);
  if (!cloud.frame_id.empty() && cloud.frame_id.find('\n') == std::string::npos) {
    out += "\ncomment ";
    out += kFrameKey;
    out += ' ' + cloud.frame_id;
  }
  out += "\nelement vertex " + std::to_string(idx.size()) +
         "\nproperty float x\nproperty float y\nproperty float z\n";
  if (cloud.hasIntensity()) out += "property float intensity\n";
  if (cloud.hasColors()) out += "property uchar red\nproperty uchar green\nproperty uchar blue\n";
  out += "end_header\n";
  const bool big = format == PlyFormat::BinaryBigEndian;
  out.reserve(out.size() + idx.size() * (format == PlyFormat::Ascii ? 48 : 19));
  for (std::size_t i : idx) {
    const auto& p = cloud.points[i];
    if (format == PlyFormat::Ascii) {
      for (int k = 0; k < 3; ++k) {
        if (k) out += ' ';
        appendNumber(out, p[k]);
      }
      if (cloud.hasIntensity()) {
        out += ' ';
        appendNumber(out, cloud.intensity[i]);
      }
      if (cloud.hasColors())
        for (int k = 0; k < 3; ++k) {
          out += ' ';
          appendNumber(out, static_cast<unsigned long>(cloud.colors[i][k]));
        }
      out += '\n';
    } else {
      for (int k = 0; k < 3; ++k) appendBinary(out, p[k], big);
      if (cloud.hasIntensity()) appendBinary(out, cloud.intensity[i], big);
      if (cloud.hasColors())
        for (int k = 0; k < 3; ++k) out += static_cast<char>(cloud.colors[i][k]);
    }
  }
  writeFileAtomically(
      path,
      [&](std::ostream& os) { os.write(out.data(), static_cast<std::streamsize>(out.size())); },
      true);
  return res;
}

// ----------------------------------------------------------------------------------------------
// PCD

namespace {

struct PcdField {
  std::string name;
  std::size_t size = 4;
  char type = 'F';
  std::size_t count = 1;
  std::size_t offset = 0;       ///< byte offset in a binary record
  std::size_t first_token = 0;  ///< index of its first value in an ascii line
};

/// Decodes one little-endian binary value of a PCD field.
double pcdBinaryValue(const unsigned char* b, const PcdField& f) {
  unsigned char v[8];
  std::memcpy(v, b, f.size);
  if (!detail::hostIsLittleEndian()) std::reverse(v, v + f.size);
  switch (f.type) {
    case 'F':
      if (f.size == 4) {
        float x;
        std::memcpy(&x, v, 4);
        return x;
      } else {
        double x;
        std::memcpy(&x, v, 8);
        return x;
      }
    case 'I':
      switch (f.size) {
        case 1:
          return static_cast<std::int8_t>(v[0]);
        case 2: {
          std::int16_t x;
          std::memcpy(&x, v, 2);
          return x;
        }
        case 4: {
          std::int32_t x;
          std::memcpy(&x, v, 4);
          return x;
        }
        default: {
          std::int64_t x;
          std::memcpy(&x, v, 8);
          return static_cast<double>(x);
        }
      }
    default:  // 'U'
      switch (f.size) {
        case 1:
          return v[0];
        case 2: {
          std::uint16_t x;
          std::memcpy(&x, v, 2);
          return x;
        }
        case 4: {
          std::uint32_t x;
          std::memcpy(&x, v, 4);
          return x;
        }
        default: {
          std::uint64_t x;
          std::memcpy(&x, v, 8);
          return static_cast<double>(x);
        }
      }
  }
}

std::uint32_t pcdBinaryBits32(const unsigned char* b) {
  unsigned char v[4];
  std::memcpy(v, b, 4);
  if (!detail::hostIsLittleEndian()) std::reverse(v, v + 4);
  std::uint32_t x;
  std::memcpy(&x, v, 4);
  return x;
}

/// Packed colour in ascii: PCL writes the unsigned integer (newer versions) or the float whose
/// bits hold it (older ones); both are accepted.
bool pcdAsciiBits32(std::string_view tok, char type, std::uint32_t& bits) {
  if (type != 'F' || tok.find_first_not_of("0123456789") == std::string_view::npos) {
    unsigned long long u = 0;
    long long s = 0;
    if (parseNumber(tok, u) && u <= 0xffffffffULL) {
      bits = static_cast<std::uint32_t>(u);
      return true;
    }
    if (parseNumber(tok, s) && s >= INT32_MIN && s <= INT32_MAX) {
      bits = static_cast<std::uint32_t>(static_cast<std::int32_t>(s));
      return true;
    }
    return false;
  }
  float f = 0;
  if (!parseNumber(tok, f)) return false;
  std::memcpy(&bits, &f, 4);
  return true;
}

Color3u8 unpackRgb(std::uint32_t bits) {
  return Color3u8(static_cast<std::uint8_t>((bits >> 16) & 0xff),
                  static_cast<std::uint8_t>((bits >> 8) & 0xff),
                  static_cast<std::uint8_t>(bits & 0xff));
}

}  // namespace

PointCloudReadResult parsePcd(std::string_view data, const std::string& file) {
  PointCloudReadResult r;
  LineCursor cur(data);
  std::string_view line;
  std::vector<std::string_view> tok;
  std::vector<PcdField> fields;
  std::vector<std::string_view> sizes, types, counts;
  std::size_t sizes_line = 0, types_line = 0, counts_line = 0, fields_line = 0;
  long long width = -1, height = -1, points = -1;
  std::size_t points_line = 0;
  std::string data_kind;
  std::size_t data_line = 0;
  std::size_t data_line_start = 0;
  while (data_kind.empty()) {
    if (!cur.next(line)) throw FormatError(file, cur.lineNumber(), "PCD header has no DATA line");
    const std::size_t ln = cur.lineNumber();
    const std::string_view t = trim(line);
    if (t.empty()) continue;
    if (t.front() == '#') {
      applyComment(t.substr(1), r.cloud);
      continue;
    }
    splitBlanks(t, tok);
    const std::string key(tok[0]);
    const auto needs = [&](std::size_t n) {
      if (tok.size() < n + 1)
        throw FormatError(file, ln, key + " needs " + std::to_string(n) + " value(s)");
    };
    const auto integer = [&](std::size_t i) {
      long long v = -1;
      if (!parseNumber(tok[i], v) || v < 0)
        throw FormatError(file, ln,
                          key + ": '" + std::string(tok[i]) + "' is not a non-negative integer");
      return v;
    };
    if (key == "VERSION") {
      continue;
    } else if (key == "FIELDS" || key == "COLUMNS") {  // COLUMNS: PCD v0.5
      needs(1);
      fields.clear();
      for (std::size_t i = 1; i < tok.size(); ++i) fields.push_back({std::string(tok[i])});
      fields_line = ln;
    } else if (key == "SIZE") {
      needs(1);
      sizes.assign(tok.begin() + 1, tok.end());
      sizes_line = ln;
    } else if (key == "TYPE") {
      needs(1);
      types.assign(tok.begin() + 1, tok.end());
      types_line = ln;
    } else if (key == "COUNT") {
      needs(1);
      counts.assign(tok.begin() + 1, tok.end());
      counts_line = ln;
    } else if (key == "WIDTH") {
      needs(1);
      width = integer(1);
    } else if (key == "HEIGHT") {
      needs(1);
      height = integer(1);
    } else if (key == "POINTS") {
      needs(1);
      points = integer(1);
      points_line = ln;
    } else if (key == "VIEWPOINT") {
      needs(7);
    } else if (key == "DATA") {
      needs(1);
      data_kind = std::string(tok[1]);
      data_line = ln;
      data_line_start = static_cast<std::size_t>(line.data() - data.data());
    } else {
      throw FormatError(file, ln, "unknown PCD header key '" + key + "'");
    }
  }
  // Consistency of the per-field lines, with the line that is wrong.
  if (fields.empty()) throw FormatError(file, data_line, "PCD header has no FIELDS line");
  const auto sameCount = [&](const std::vector<std::string_view>& v, std::size_t ln,
                             const char* key) {
    if (ln == 0)
      throw FormatError(file, data_line, std::string("PCD header has no ") + key + " line");
    if (v.size() != fields.size())
      throw FormatError(file, ln,
                        std::string(key) + " has " + std::to_string(v.size()) + " entries for " +
                            std::to_string(fields.size()) + " FIELDS");
  };
  sameCount(sizes, sizes_line, "SIZE");
  sameCount(types, types_line, "TYPE");
  if (counts_line) sameCount(counts, counts_line, "COUNT");
  std::size_t record = 0, ntokens = 0;
  for (std::size_t i = 0; i < fields.size(); ++i) {
    auto& f = fields[i];
    long long s = 0, c = 1;
    if (!parseNumber(sizes[i], s) || (s != 1 && s != 2 && s != 4 && s != 8))
      throw FormatError(file, sizes_line,
                        "SIZE of field '" + f.name + "' must be 1, 2, 4 or 8, found '" +
                            std::string(sizes[i]) + "'");
    if (types[i].size() != 1 || std::string_view("FIU").find(types[i][0]) == std::string_view::npos)
      throw FormatError(file, types_line,
                        "TYPE of field '" + f.name + "' must be F, I or U, found '" +
                            std::string(types[i]) + "'");
    if (types[i][0] == 'F' && s != 4 && s != 8)
      throw FormatError(file, sizes_line, "float field '" + f.name + "' must have SIZE 4 or 8");
    if (counts_line && (!parseNumber(counts[i], c) || c < 1))
      throw FormatError(file, counts_line,
                        "COUNT of field '" + f.name + "' must be a positive integer");
    f.size = static_cast<std::size_t>(s);
    f.type = types[i][0];
    f.count = static_cast<std::size_t>(c);
    f.offset = record;
    f.first_token = ntokens;
    record += f.size * f.count;
    ntokens += f.count;
  }
  const auto findField = [&](std::string_view n) -> int {
    for (std::size_t i = 0; i < fields.size(); ++i)
      if (fields[i].name == n) return static_cast<int>(i);
    return -1;
  };
  const int ix = findField("x"), iy = findField("y"), iz = findField("z");
  if (ix < 0 || iy < 0 || iz < 0) throw FormatError(file, fields_line, "FIELDS has no x, y and z");
  const int ii = findField("intensity");
  int irgb = findField("rgb");
  if (irgb < 0) irgb = findField("rgba");
  if (irgb >= 0 && fields[static_cast<std::size_t>(irgb)].size != 4)
    throw FormatError(file, sizes_line, "packed colour field must have SIZE 4");
  if (points < 0) {
    if (width < 0 || height < 0)
      throw FormatError(file, data_line, "PCD header has neither POINTS nor WIDTH and HEIGHT");
    points = width * height;
  } else if (width >= 0 && height >= 0 && width * height != points) {
    throw FormatError(file, points_line,
                      "POINTS " + std::to_string(points) +
                          " differs from WIDTH × HEIGHT = " + std::to_string(width * height));
  }
  const auto n = static_cast<std::size_t>(points);
  if (data_kind == "binary_compressed")
    throw FormatError(
        file, data_line,
        "DATA binary_compressed is not supported (save the cloud as binary or ascii)");
  auto& cloud = r.cloud;
  const auto F = [&fields](int i) -> const PcdField& {
    return fields[static_cast<std::size_t>(i)];
  };
  const auto allocate = [&] {
    cloud.points.resize(n);
    if (ii >= 0) cloud.intensity.resize(n);
    if (irgb >= 0) cloud.colors.resize(n);
  };
  if (data_kind == "binary") {
    // The body starts after the '\n' that ends the DATA line (PCL writes '\n' line ends).
    const std::size_t nl = data.find('\n', data_line_start);
    const std::size_t body = nl == std::string_view::npos ? data.size() : nl + 1;
    const double need = static_cast<double>(n) * static_cast<double>(record);
    if (need > static_cast<double>(data.size() - std::min(body, data.size())))
      throw FormatError(file, 0,
                        "binary PCD data is truncated: " + std::to_string(n) + " points of " +
                            std::to_string(record) + " bytes need " +
                            std::to_string(static_cast<unsigned long long>(need)) +
                            " bytes, the file has " +
                            std::to_string(data.size() - std::min(body, data.size())));
    allocate();
    const auto* base = reinterpret_cast<const unsigned char*>(data.data()) + body;
    for (std::size_t i = 0; i < n; ++i) {
      const unsigned char* rec = base + i * record;
      cloud.points[i] = Vector3f(static_cast<float>(pcdBinaryValue(rec + F(ix).offset, F(ix))),
                                 static_cast<float>(pcdBinaryValue(rec + F(iy).offset, F(iy))),
                                 static_cast<float>(pcdBinaryValue(rec + F(iz).offset, F(iz))));
      if (ii >= 0)
        cloud.intensity[i] = static_cast<float>(pcdBinaryValue(rec + F(ii).offset, F(ii)));
      if (irgb >= 0) cloud.colors[i] = unpackRgb(pcdBinaryBits32(rec + F(irgb).offset));
    }
  } else if (data_kind == "ascii") {
    // Grown point by point (reserving at most what the rest of the file can hold: two
    // characters per value), so a corrupt POINTS count cannot trigger a huge allocation.
    const std::size_t cap = std::min<std::size_t>(
        n, (data.size() - cur.offset()) / std::max<std::size_t>(1, 2 * ntokens) + 1);
    cloud.points.reserve(cap);
    if (ii >= 0) cloud.intensity.reserve(cap);
    if (irgb >= 0) cloud.colors.reserve(cap);
    std::size_t i = 0;
    while (i < n) {
      if (!cur.next(line))
        throw FormatError(file, cur.lineNumber(),
                          "ascii PCD data ends after " + std::to_string(i) + " of " +
                              std::to_string(n) + " points");
      const std::size_t ln = cur.lineNumber();
      splitBlanks(line, tok);
      if (tok.empty()) continue;
      if (tok.size() != ntokens)
        throw FormatError(file, ln,
                          "point " + std::to_string(i) + " has " + std::to_string(tok.size()) +
                              " values, the header declares " + std::to_string(ntokens));
      const auto val = [&](int f) {
        return static_cast<float>(
            detail::parseDouble(tok[F(f).first_token], file, ln, "field '" + F(f).name + "'"));
      };
      cloud.points.emplace_back(val(ix), val(iy), val(iz));
      if (ii >= 0) cloud.intensity.push_back(val(ii));
      if (irgb >= 0) {
        std::uint32_t bits = 0;
        const std::string_view t = tok[F(irgb).first_token];
        if (!pcdAsciiBits32(t, F(irgb).type, bits))
          throw FormatError(file, ln, "packed colour '" + std::string(t) + "' is not a number");
        cloud.colors.push_back(unpackRgb(bits));
      }
      ++i;
    }
  } else {
    throw FormatError(file, data_line,
                      "unknown DATA kind '" + data_kind + "' (expected ascii or binary)");
  }
  finishRead(r);
  return r;
}

PointCloudReadResult readPcd(const std::string& path) {
  return parsePcd(detail::readWholeFile(path), path);
}

PointCloudWriteResult writePcd(const std::string& path, const PointCloud& cloud, bool binary) {
  cloud.validate();
  PointCloudWriteResult res;
  const auto idx = finiteIndices(cloud, res.num_nonfinite_dropped);
  res.num_written = idx.size();
  const bool wi = cloud.hasIntensity(), wc = cloud.hasColors();
  std::string out = "# .PCD v0.7 - Point Cloud Data file format\n# ";
  out += kTimestampKey;
  out += ' ';
  appendNumber(out, cloud.timestamp);
  if (!cloud.frame_id.empty() && cloud.frame_id.find('\n') == std::string::npos) {
    out += "\n# ";
    out += kFrameKey;
    out += ' ' + cloud.frame_id;
  }
  // rgb is a 4-byte float field holding 0xAARRGGBB, as PCL's PointXYZRGB declares it.
  out += std::string("\nVERSION 0.7\nFIELDS x y z") + (wi ? " intensity" : "") +
         (wc ? " rgb" : "") + "\nSIZE 4 4 4" + (wi ? " 4" : "") + (wc ? " 4" : "") +
         "\nTYPE F F F" + (wi ? " F" : "") + (wc ? " F" : "") + "\nCOUNT 1 1 1" + (wi ? " 1" : "") +
         (wc ? " 1" : "") + "\nWIDTH " + std::to_string(idx.size()) +
         "\nHEIGHT 1\nVIEWPOINT 0 0 0 1 0 0 0\nPOINTS " + std::to_string(idx.size()) + "\nDATA " +
         (binary ? "binary" : "ascii") + "\n";
  out.reserve(out.size() + idx.size() * (binary ? 20 : 48));
  for (std::size_t i : idx) {
    const auto& p = cloud.points[i];
    std::uint32_t rgb = 0;
    if (wc) {
      const auto& c = cloud.colors[i];
      rgb = 0xff000000u | (std::uint32_t(c[0]) << 16) | (std::uint32_t(c[1]) << 8) | c[2];
    }
    if (binary) {
      for (int k = 0; k < 3; ++k) appendBinary(out, p[k], false);
      if (wi) appendBinary(out, cloud.intensity[i], false);
      if (wc) appendBinary(out, rgb, false);
    } else {
      for (int k = 0; k < 3; ++k) {
        if (k) out += ' ';
        appendNumber(out, p[k]);
      }
      if (wi) {
        out += ' ';
        appendNumber(out, cloud.intensity[i]);
      }
      if (wc) {  // the integer, as PCL writes packed colours in ascii
        out += ' ';
        appendNumber(out, static_cast<unsigned long>(rgb));
      }
      out += '\n';
    }
  }
  writeFileAtomically(
      path,
      [&](std::ostream& os) { os.write(out.data(), static_cast<std::streamsize>(out.size())); },
      true);
  return res;
}

// ----------------------------------------------------------------------------------------------
// OFF

PointCloudReadResult parseOffPointCloud(std::string_view data, const std::string& file) {
  PointCloudReadResult r;
  LineCursor cur(data);
  const detail::OffHeader h = detail::parseOffHeader(cur, file);
  std::vector<std::string_view> tok;
  auto& cloud = r.cloud;
  const std::size_t cap = detail::offLinesCapacity(cur, h.num_vertices, 6);
  cloud.points.reserve(cap);
  if (h.colors) cloud.colors.reserve(cap);
  Eigen::Vector3f p;
  Color3u8 c = Color3u8::Zero();
  bool has_c = false, all_c = true;
  for (std::size_t v = 0; v < h.num_vertices; ++v) {
    detail::parseOffVertex(cur, h, v, file, tok, p, c, has_c);
    cloud.points.push_back(p);
    if (h.colors) cloud.colors.push_back(has_c ? c : Color3u8::Zero());
    all_c = all_c && has_c;
  }
  if (h.colors && !all_c) cloud.colors.clear();  // a COFF without colours on every vertex
  finishRead(r);
  return r;
}

PointCloudReadResult readOffPointCloud(const std::string& path) {
  return parseOffPointCloud(detail::readWholeFile(path), path);
}

// ------------------------------------------------------------------------------------ dispatching

PointCloudReadResult readPointCloudDetailed(const std::string& path) {
  const std::string ext = detail::lowerExtension(path);
  if (ext == "ply") return readPlyPointCloud(path);
  if (ext == "pcd") return readPcd(path);
  if (ext == "off") return readOffPointCloud(path);
  throw FormatError(path, 0,
                    "unknown point-cloud extension '." + ext + "' (expected .ply, .pcd or .off)");
}

PointCloud readPointCloud(const std::string& path) {
  PointCloudReadResult r = readPointCloudDetailed(path);
  if (r.num_nonfinite_dropped > 0)
    OBM_LOG_WARN(kLog, path << ": dropped " << r.num_nonfinite_dropped << " of " << r.num_in_file
                            << " points with a NaN or infinite coordinate");
  return std::move(r.cloud);
}

PointCloudWriteResult writePointCloud(const std::string& path, const PointCloud& cloud,
                                      bool binary) {
  const std::string ext = detail::lowerExtension(path);
  if (ext == "ply")
    return writePly(path, cloud, binary ? PlyFormat::BinaryLittleEndian : PlyFormat::Ascii);
  if (ext == "pcd") return writePcd(path, cloud, binary);
  throw FormatError(path, 0,
                    "cannot write point-cloud extension '." + ext + "' (expected .ply or .pcd)");
}

}  // namespace obm::io
