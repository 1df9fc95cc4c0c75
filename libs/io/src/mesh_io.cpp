#include "obm/io/mesh_io.hpp"

#include <cmath>
#include <filesystem>
#include <limits>
#include <locale>
#include <ostream>

#include "obm/core/atomic_file.hpp"
#include "obm/core/errors.hpp"
#include "off_codec.hpp"
#include "ply_codec.hpp"
#include "text_parse.hpp"

namespace obm::io {
namespace {

using detail::LineCursor;
using detail::parseNumber;
using detail::splitBlanks;

std::string stemOf(const std::string& file) {
  return std::filesystem::path(file).stem().string();
}

/// Strips a `#` comment and surrounding blanks.
std::string_view stripComment(std::string_view line) {
  const std::size_t h = line.find('#');
  if (h != std::string_view::npos) line = line.substr(0, h);
  return detail::trim(line);
}

/// Appends the fan triangulation of a polygon given by its corner indices.
void appendFan(const std::vector<int>& corners, TriangleMesh& mesh) {
  for (std::size_t i = 1; i + 1 < corners.size(); ++i)
    mesh.faces.emplace_back(corners[0], corners[i], corners[i + 1]);
}

}  // namespace

// ----------------------------------------------------------------------------------------------
// OFF

TriangleMesh parseOff(std::string_view text, const std::string& file) {
  TriangleMesh mesh;
  mesh.name = stemOf(file);
  LineCursor cur(text);
  std::string_view line;
  std::vector<std::string_view> tok;
  const detail::OffHeader h = detail::parseOffHeader(cur, file);
  const long long nv = static_cast<long long>(h.num_vertices);
  const long long nf = static_cast<long long>(h.num_faces);
  mesh.vertices.reserve(detail::offLinesCapacity(cur, h.num_vertices, 6));
  Color3u8 color;
  bool has_color = false;
  Eigen::Vector3f p;
  for (std::size_t v = 0; v < h.num_vertices; ++v) {
    detail::parseOffVertex(cur, h, v, file, tok, p, color, has_color);
    mesh.vertices.push_back(p);
  }
  mesh.faces.reserve(detail::offLinesCapacity(cur, h.num_faces, 8));
  std::vector<int> corners;
  for (long long f = 0; f < nf; ++f) {
    if (!detail::nextOffLine(cur, line))
      throw FormatError(
          file, cur.lineNumber(),
          "file ends after " + std::to_string(f) + " of " + std::to_string(nf) + " faces");
    splitBlanks(line, tok);
    long long n = 0;
    if (!parseNumber(tok[0], n) || n < 3)
      throw FormatError(file, cur.lineNumber(),
                        "face " + std::to_string(f) + ": expected a corner count >= 3, found '" +
                            std::string(tok[0]) + "'");
    if (tok.size() < static_cast<std::size_t>(n) + 1)
      throw FormatError(
          file, cur.lineNumber(),
          "face " + std::to_string(f) + " lists fewer than " + std::to_string(n) + " corners");
    corners.clear();
    for (long long k = 1; k <= n; ++k) {  // anything after the corners is a colour: ignored
      long long idx = -1;
      if (!parseNumber(tok[static_cast<std::size_t>(k)], idx) || idx < 0 || idx >= nv)
        throw FormatError(file, cur.lineNumber(),
                          "face " + std::to_string(f) + ": vertex index '" +
                              std::string(tok[static_cast<std::size_t>(k)]) + "' is not in [0, " +
                              std::to_string(nv) + ")");
      corners.push_back(static_cast<int>(idx));
    }
    appendFan(corners, mesh);
  }
  return mesh;
}

TriangleMesh readOff(const std::string& path) {
  return parseOff(detail::readWholeFile(path), path);
}

// ----------------------------------------------------------------------------------------------
// PLY

TriangleMesh parsePlyMesh(std::string_view data, const std::string& file) {
  const detail::PlyHeader h = detail::parsePlyHeader(file, data);
  detail::PlyBodyReader body(file, data, h);
  TriangleMesh mesh;
  mesh.name = stemOf(file);
  bool have_vertices = false;
  std::size_t nv = 0;
  std::vector<double> values;
  std::vector<std::vector<double>> lists;
  std::vector<int> corners;
  for (const auto& el : h.elements) {
    if (el.name == "vertex") {
      const int ix = el.find("x"), iy = el.find("y"), iz = el.find("z");
      if (ix < 0 || iy < 0 || iz < 0)
        throw FormatError(file, el.header_line, "element 'vertex' has no x, y and z properties");
      for (int i : {ix, iy, iz})
        if (el.properties[static_cast<std::size_t>(i)].is_list)
          throw FormatError(file, el.header_line, "vertex coordinates must not be lists");
      mesh.vertices.reserve(el.count);
      for (std::size_t i = 0; i < el.count; ++i) {
        body.read(el, i, values, lists);
        mesh.vertices.emplace_back(static_cast<float>(values[static_cast<std::size_t>(ix)]),
                                   static_cast<float>(values[static_cast<std::size_t>(iy)]),
                                   static_cast<float>(values[static_cast<std::size_t>(iz)]));
      }
      have_vertices = true;
      nv = el.count;
    } else if (el.name == "face") {
      if (!have_vertices)
        throw FormatError(file, el.header_line, "element 'face' comes before element 'vertex'");
      int il = el.find("vertex_indices");
      if (il < 0) il = el.find("vertex_index");
      if (il < 0 || !el.properties[static_cast<std::size_t>(il)].is_list)
        throw FormatError(file, el.header_line,
                          "element 'face' has no 'vertex_indices' list property");
      mesh.faces.reserve(el.count);
      for (std::size_t f = 0; f < el.count; ++f) {
        body.read(el, f, values, lists);
        const auto& items = lists[static_cast<std::size_t>(il)];
        if (items.size() < 3)
          throw FormatError(file, body.line(),
                            "face " + std::to_string(f) + " has " + std::to_string(items.size()) +
                                " corners (at least 3 needed)");
        corners.clear();
        for (double d : items) {
          if (!(d >= 0) || d >= static_cast<double>(nv) || d != std::floor(d))
            throw FormatError(file, body.line(),
                              "face " + std::to_string(f) + ": vertex index " + std::to_string(d) +
                                  " is not in [0, " + std::to_string(nv) + ")");
          corners.push_back(static_cast<int>(d));
        }
        appendFan(corners, mesh);
      }
    } else {
      body.skip(el);
    }
  }
  if (!have_vertices) throw FormatError(file, 0, "PLY file has no 'vertex' element");
  return mesh;
}

TriangleMesh readPlyMesh(const std::string& path) {
  return parsePlyMesh(detail::readWholeFile(path), path);
}

// ----------------------------------------------------------------------------------------------
// OBJ

TriangleMesh parseObj(std::string_view text, const std::string& file) {
  TriangleMesh mesh;
  mesh.name = stemOf(file);
  LineCursor cur(text);
  std::string_view raw;
  std::string joined;
  std::vector<std::string_view> tok;
  std::vector<int> corners;
  // Faces may in principle refer to vertices defined further down; such references are checked
  // once the whole file is read.
  std::size_t forward_line = 0;
  long long forward_max = -1;
  while (cur.next(raw)) {
    const std::size_t ln = cur.lineNumber();
    std::string_view line = stripComment(raw);
    if (!line.empty() && line.back() == '\\') {  // line continuation
      joined.assign(line.substr(0, line.size() - 1));
      while (cur.next(raw)) {
        std::string_view more = stripComment(raw);
        const bool again = !more.empty() && more.back() == '\\';
        if (again) more.remove_suffix(1);
        joined.push_back(' ');
        joined.append(more);
        if (!again) break;
      }
      line = joined;
    }
    splitBlanks(line, tok);
    if (tok.empty()) continue;
    if (tok[0] == "v") {
      if (tok.size() < 4) throw FormatError(file, ln, "vertex needs x y z");
      double c[3];
      for (int k = 0; k < 3; ++k)
        c[k] = detail::parseDouble(tok[static_cast<std::size_t>(k) + 1], file, ln, "vertex");
      mesh.vertices.emplace_back(static_cast<float>(c[0]), static_cast<float>(c[1]),
                                 static_cast<float>(c[2]));
    } else if (tok[0] == "f") {
      if (tok.size() < 4)
        throw FormatError(file, ln,
                          "face needs at least 3 corners, found " + std::to_string(tok.size() - 1));
      corners.clear();
      const long long nv = static_cast<long long>(mesh.vertices.size());
      for (std::size_t k = 1; k < tok.size(); ++k) {
        std::string_view c = tok[k];
        c = c.substr(0, c.find('/'));  // v, v/vt, v//vn, v/vt/vn: the vertex index comes first
        long long idx = 0;
        if (!parseNumber(c, idx) || idx == 0)
          throw FormatError(file, ln,
                            "face corner '" + std::string(tok[k]) +
                                "' does not start with a non-zero vertex index");
        if (idx < 0) {
          idx += nv;  // relative: -1 is the last vertex read so far
          if (idx < 0)
            throw FormatError(file, ln,
                              "relative vertex index " + std::string(c) + " reaches before the " +
                                  "first vertex (" + std::to_string(nv) + " read so far)");
        } else {
          idx -= 1;
          if (idx >= nv && idx > forward_max) {
            forward_max = idx;
            forward_line = ln;
          }
        }
        if (idx > std::numeric_limits<int>::max())
          throw FormatError(file, ln, "vertex index too large");
        corners.push_back(static_cast<int>(idx));
      }
      appendFan(corners, mesh);
    }
    // Everything else (vt, vn, vp, g, o, s, l, p, usemtl, mtllib, ...) carries no geometry here.
  }
  if (forward_max >= static_cast<long long>(mesh.vertices.size()))
    throw FormatError(file, forward_line,
                      "face refers to vertex " + std::to_string(forward_max + 1) +
                          " but the file has " + std::to_string(mesh.vertices.size()) +
                          " vertices");
  return mesh;
}

TriangleMesh readObj(const std::string& path) {
  return parseObj(detail::readWholeFile(path), path);
}

// ------------------------------------------------------------------------------------ dispatching

TriangleMesh readMesh(const std::string& path) {
  const std::string ext = detail::lowerExtension(path);
  if (ext == "off") return readOff(path);
  if (ext == "ply") return readPlyMesh(path);
  if (ext == "obj") return readObj(path);
  throw FormatError(path, 0, "unknown mesh extension '." + ext + "' (expected .off, .ply or .obj)");
}

void writeMesh(const std::string& path, const TriangleMesh& mesh) {
  mesh.validate();
  const std::string ext = detail::lowerExtension(path);
  if (ext != "off" && ext != "ply" && ext != "obj")
    throw FormatError(path, 0,
                      "unknown mesh extension '." + ext + "' (expected .off, .ply or .obj)");
  writeFileAtomically(path, [&](std::ostream& os) {
    os.imbue(std::locale::classic());
    os.precision(std::numeric_limits<float>::max_digits10);
    if (ext == "off") {
      os << "OFF\n" << mesh.vertices.size() << ' ' << mesh.faces.size() << " 0\n";
    } else if (ext == "ply") {
      os << "ply\nformat ascii 1.0\nelement vertex " << mesh.vertices.size()
         << "\nproperty float x\nproperty float y\nproperty float z\nelement face "
         << mesh.faces.size() << "\nproperty list uchar int vertex_indices\nend_header\n";
    } else {
      os << "# " << mesh.vertices.size() << " vertices, " << mesh.faces.size() << " faces\n";
    }
    const char* vprefix = ext == "obj" ? "v " : "";
    for (const auto& v : mesh.vertices)
      os << vprefix << v.x() << ' ' << v.y() << ' ' << v.z() << '\n';
    for (const auto& f : mesh.faces) {
      if (ext == "obj")
        os << "f " << f[0] + 1 << ' ' << f[1] + 1 << ' ' << f[2] + 1 << '\n';
      else
        os << "3 " << f[0] << ' ' << f[1] << ' ' << f[2] << '\n';
    }
  });
}

}  // namespace obm::io
