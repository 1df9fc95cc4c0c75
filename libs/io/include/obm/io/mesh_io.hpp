#pragma once
/// \file mesh_io.hpp
/// Triangle-mesh files: OFF, PLY and Wavefront OBJ read into obm::TriangleMesh, and written back.
///
/// Polygons with more than three corners are split into a triangle fan (v0, vi, vi+1), which is
/// exact for the convex faces these formats normally carry. Every reader throws obm::IoError when
/// the file cannot be read and obm::FormatError naming the file, the line (when there is one) and
/// the fault otherwise; none aborts or prints.
#include <string>
#include <string_view>

#include "obm/core/mesh.hpp"

namespace obm::io {

/// Reads a mesh, choosing the format from the extension (.off, .ply, .obj; case-insensitive).
/// The mesh's `name` is the file stem. Throws FormatError for an unknown extension.
TriangleMesh readMesh(const std::string& path);

/// Object File Format (Geomview): optional `[ST][C][N][4]OFF` keyword (so COFF, NOFF, CNOFF,
/// 4OFF ... are accepted; only the coordinates are kept), `#` comments, counts on the keyword line
/// or the next one, one vertex per line, faces as `n i0 ... i(n-1) [colour]`. The binary variant
/// (`OFF BINARY`) and dimensions other than 3 (`nOFF`) are rejected with FormatError.
TriangleMesh readOff(const std::string& path);

/// PLY mesh (ascii, binary_little_endian or binary_big_endian): `vertex` element with x, y, z
/// (any numeric type) and an optional `face` element with a `vertex_indices` (or `vertex_index`)
/// list; other elements and properties are skipped. A PLY without faces gives a mesh with
/// vertices only.
TriangleMesh readPlyMesh(const std::string& path);

/// Wavefront OBJ: `v x y z [w] [r g b]` and `f` with `v`, `v/vt`, `v//vn` or `v/vt/vn` corners
/// (1-based; negative indices count back from the last vertex read). Other statements (vt, vn,
/// g, o, s, usemtl, mtllib, l, p ...) are ignored; `\` continues a line.
TriangleMesh readObj(const std::string& path);

/// The parsers behind the readers, on text already in memory; `file` names it in messages.
TriangleMesh parseOff(std::string_view text, const std::string& file);
TriangleMesh parsePlyMesh(std::string_view data, const std::string& file);
TriangleMesh parseObj(std::string_view text, const std::string& file);

/// Writes `mesh` as ascii OFF, PLY or OBJ chosen from the extension, atomically (temporary file
/// + rename). Coordinates are written with 9 significant digits, so floats read back exactly.
/// Throws ContractError for an invalid mesh, FormatError for an unknown extension and IoError when
/// the file cannot be written.
void writeMesh(const std::string& path, const TriangleMesh& mesh);

}  // namespace obm::io
