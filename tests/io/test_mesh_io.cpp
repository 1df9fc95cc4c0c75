#include <gtest/gtest.h>

#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <string>

#include "obm/core/errors.hpp"
#include "obm/io/mesh_io.hpp"
#include "test_data.hpp"

using namespace obm;
namespace fs = std::filesystem;

namespace {

std::string writeFile(const std::string& dir, const std::string& name, const std::string& text) {
  const std::string p = dir + "/" + name;
  std::ofstream(p, std::ios::binary) << text;
  return p;
}

/// Expects `fn` to throw FormatError whose message contains every fragment.
template <typename Fn>
void expectFormatError(Fn fn, std::initializer_list<std::string> fragments) {
  try {
    fn();
    ADD_FAILURE() << "no FormatError thrown";
  } catch (const FormatError& e) {
    for (const auto& f : fragments)
      EXPECT_NE(std::string(e.what()).find(f), std::string::npos)
          << "'" << f << "' missing in: " << e.what();
  }
}

// A unit square split into two triangles in the z = 0 plane: area 1.
const char* kQuadOff =
    "# a comment before the keyword\n"
    "OFF\n"
    "4 1 0   # counts\n"
    "\n"
    "0 0 0\n"
    "1 0 0\n"
    "1 1 0  # trailing comment\n"
    "0 1 0\n"
    "4 0 1 2 3\n";

}  // namespace

TEST(MeshIo, OffPolygonIsFanTriangulated) {
  const auto dir = test::scratchDir("mesh_off");
  const auto m = io::readMesh(writeFile(dir, "quad.off", kQuadOff));
  ASSERT_EQ(m.numVertices(), 4u);
  ASSERT_EQ(m.numFaces(), 2u);
  EXPECT_EQ(m.faces[0], Eigen::Vector3i(0, 1, 2));
  EXPECT_EQ(m.faces[1], Eigen::Vector3i(0, 2, 3));
  EXPECT_NEAR(m.area(), 1.0, 1e-12);
  EXPECT_EQ(m.name, "quad");
  EXPECT_FLOAT_EQ(m.vertices[2].y(), 1.f);
}

TEST(MeshIo, OffVariantsCountsOnKeywordLineAndColours) {
  // COFF: vertices carry RGBA after xyz, faces a colour after the indices.
  const std::string coff =
      "COFF 3 1 0\n"
      "0 0 0 255 0 0 255\n"
      "2 0 0 0 255 0 255\n"
      "0 3 0 0 0 255 255\n"
      "3 0 1 2 10 20 30\n";
  const auto m = io::parseOff(coff, "c.off");
  ASSERT_EQ(m.numFaces(), 1u);
  EXPECT_NEAR(m.area(), 3.0, 1e-12);
  // NOFF: normals after xyz. 4OFF: homogeneous coordinates divided by w.
  const auto n =
      io::parseOff("NOFF\n3 1 0\n0 0 0 0 0 1\n1 0 0 0 0 1\n0 1 0 0 0 1\n3 0 1 2\n", "n.off");
  EXPECT_NEAR(n.area(), 0.5, 1e-12);
  const auto h = io::parseOff("4OFF\n3 1 0\n0 0 0 1\n4 0 0 2\n0 2 0 1\n3 0 1 2\n", "h.off");
  EXPECT_FLOAT_EQ(h.vertices[1].x(), 2.f);
  EXPECT_NEAR(h.area(), 2.0, 1e-12);
  // The keyword itself is optional.
  const auto k = io::parseOff("3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 2 1 0\n", "k.off");
  EXPECT_EQ(k.faces[0], Eigen::Vector3i(2, 1, 0));
}

TEST(MeshIo, OffErrorsNameFileAndLine) {
  expectFormatError([] { io::parseOff("OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 7\n", "bad.off"); },
                    {"bad.off:6", "'7'", "[0, 3)"});
  expectFormatError([] { io::parseOff("OFF\n3 1 0\n0 0 0\n1 0\n", "short.off"); },
                    {"short.off:4", "vertex 1"});
  expectFormatError([] { io::parseOff("OFF\n3 1 0\n0 0 0\n1 0 0\n", "trunc.off"); },
                    {"trunc.off", "2 of 3 vertices"});
  expectFormatError([] { io::parseOff("OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n2 0 1\n", "deg.off"); },
                    {"deg.off:6", "corner count"});
  expectFormatError([] { io::parseOff("PLY\n", "kw.off"); }, {"kw.off:1", "OFF"});
  expectFormatError([] { io::parseOff("OFF BINARY\n", "b.off"); }, {"b.off:1", "binary"});
  expectFormatError([] { io::parseOff("OFF\n3 x 0\n", "c.off"); }, {"c.off:2", "counts"});
  EXPECT_THROW(io::readOff("/nonexistent/x.off"), IoError);
  EXPECT_THROW(io::readMesh("/nonexistent/x.stl"), FormatError);
}

TEST(MeshIo, PlyAsciiAndBinaryWithExtraProperties) {
  const auto dir = test::scratchDir("mesh_ply");
  // Extra vertex properties (a normal, a colour) and an extra element must be skipped.
  const std::string ascii =
      "ply\nformat ascii 1.0\ncomment made by a test\n"
      "element vertex 4\nproperty double x\nproperty double y\nproperty double z\n"
      "property float nx\nproperty uchar red\n"
      "element face 1\nproperty list uchar int vertex_indices\n"
      "element edge 1\nproperty int vertex1\nproperty int vertex2\n"
      "end_header\n"
      "0 0 0 0 1\n2 0 0 0 2\n2 2 0 0 3\n0 2 0 0 4\n4 0 1 2 3\n0 1\n";
  const auto a = io::readMesh(writeFile(dir, "a.ply", ascii));
  ASSERT_EQ(a.numVertices(), 4u);
  ASSERT_EQ(a.numFaces(), 2u);
  EXPECT_NEAR(a.area(), 4.0, 1e-12);

  // Same geometry in binary little endian with a ushort count and uint indices.
  std::string bin =
      "ply\nformat binary_little_endian 1.0\n"
      "element vertex 3\nproperty float x\nproperty float y\nproperty float z\n"
      "element face 1\nproperty list ushort uint vertex_index\nend_header\n";
  auto put = [&bin](const void* p, std::size_t n) { bin.append(static_cast<const char*>(p), n); };
  const float vs[9] = {0, 0, 0, 3, 0, 0, 0, 4, 0};
  put(vs, sizeof vs);
  const std::uint16_t n = 3;
  const std::uint32_t idx[3] = {0, 1, 2};
  put(&n, 2);
  put(idx, sizeof idx);
  const auto b = io::parsePlyMesh(bin, "b.ply");
  ASSERT_EQ(b.numFaces(), 1u);
  EXPECT_NEAR(b.area(), 6.0, 1e-12);
  EXPECT_FLOAT_EQ(b.vertices[2].y(), 4.f);

  expectFormatError([&] { io::parsePlyMesh(bin.substr(0, bin.size() - 3), "t.ply"); },
                    {"t.ply", "truncated", "'face'"});
  expectFormatError(
      [] {
        io::parsePlyMesh("ply\nformat ascii 1.0\nelement vertex 1\nproperty flot x\nend_header\n",
                         "h.ply");
      },
      {"h.ply:4", "flot"});
  expectFormatError(
      [] {
        io::parsePlyMesh(
            "ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nproperty float y\n"
            "property float z\nelement face 1\nproperty list uchar int vertex_indices\n"
            "end_header\n0 0 0\n3 0 0 5\n",
            "i.ply");
      },
      {"i.ply:11", "[0, 1)"});
}

TEST(MeshIo, ObjCornerFormsAndNegativeIndices) {
  const std::string obj =
      "# cube corner\n"
      "mtllib x.mtl\no thing\n"
      "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\n"
      "vt 0 0\nvn 0 0 1\n"
      "g side\nusemtl m\ns off\n"
      "f 1/1/1 2/1/1 3/1/1 4/1/1\n"  // quad → 2 triangles
      "f 1//1 2//1 \\\n 3//1\n"      // continued line
      "f -4 -3 -2\n"                 // relative: vertices 1 2 3
      "f 2/1 3/1 4/1\n";
  const auto m = io::parseObj(obj, "o.obj");
  ASSERT_EQ(m.numVertices(), 4u);
  ASSERT_EQ(m.numFaces(), 5u);
  EXPECT_EQ(m.faces[1], Eigen::Vector3i(0, 2, 3));
  EXPECT_EQ(m.faces[3], Eigen::Vector3i(0, 1, 2));
  EXPECT_EQ(m.faces[4], Eigen::Vector3i(1, 2, 3));
  EXPECT_NEAR(m.area(), 1.0 + 0.5 + 0.5 + 0.5, 1e-12);

  expectFormatError([] { io::parseObj("v 0 0 0\nf 1 2 3\n", "f.obj"); }, {"f.obj:2", "vertex 3"});
  expectFormatError([] { io::parseObj("v 0 0 0\nf -1 -2 -3\n", "r.obj"); }, {"r.obj:2", "-2"});
  expectFormatError([] { io::parseObj("v 0 0\n", "v.obj"); }, {"v.obj:1", "x y z"});
  expectFormatError([] { io::parseObj("v 0 0 0\nf 1 0 1\n", "z.obj"); }, {"z.obj:2", "'0'"});
}

TEST(MeshIo, WriteReadRoundTripAllFormats) {
  const auto dir = test::scratchDir("mesh_rt");
  TriangleMesh m;
  m.vertices = {{0.1f, -2.5f, 3.0f}, {1.0f / 3.0f, 0.f, 1e-7f}, {5.f, 6.f, 7.125f}, {-1, -1, -1}};
  m.faces = {{0, 1, 2}, {0, 2, 3}, {3, 2, 1}};
  for (const char* ext : {"off", "ply", "obj"}) {
    const std::string p = dir + "/m." + ext;
    io::writeMesh(p, m);
    const auto r = io::readMesh(p);
    ASSERT_EQ(r.vertices.size(), m.vertices.size()) << ext;
    for (std::size_t i = 0; i < m.vertices.size(); ++i)
      EXPECT_EQ(r.vertices[i], m.vertices[i]) << ext << " vertex " << i;  // exact: 9 digits
    EXPECT_EQ(r.faces, m.faces) << ext;
  }
  EXPECT_THROW(io::writeMesh(dir + "/m.stl", m), FormatError);
  EXPECT_THROW(io::writeMesh(dir + "/no/such/folder/m.off", m), IoError);
  m.faces.push_back({0, 1, 9});
  EXPECT_THROW(io::writeMesh(dir + "/bad.off", m), ContractError);
  EXPECT_FALSE(fs::exists(dir + "/bad.off"));
}

// Real meshes from CGAL's data (Debian libcgal-demo; scripts/get_cgal_meshes.sh prints the folder
// to put in OBM_CGAL_DATA). Skipped when the variable is unset, except in CI.
TEST(MeshIo, RealCgalMeshes) {
  OBM_REQUIRE_CGAL_DATA();
  const std::string dir = std::getenv("OBM_CGAL_DATA");
  // Every mesh of the folder reads and is consistent.
  std::size_t files = 0;
  for (const auto& e : fs::directory_iterator(dir)) {
    const std::string ext = e.path().extension().string();
    if (ext != ".off" && ext != ".ply" && ext != ".obj") continue;
    ++files;
    TriangleMesh m;
    ASSERT_NO_THROW(m = io::readMesh(e.path().string())) << e.path();
    EXPECT_GT(m.numVertices(), 0u) << e.path();
    EXPECT_NO_THROW(m.validate()) << e.path();
  }
  EXPECT_GE(files, 100u) << "expected CGAL's ~140 sample meshes in " << dir;
  for (const char* name : {"elephant.off", "cube_poly.off", "mesh_with_colors.off", "sphere.ply"}) {
    const std::string p = dir + "/" + name;
    if (!fs::exists(p)) continue;
    const auto m = io::readMesh(p);
    EXPECT_GT(m.numFaces(), 0u) << name;
    EXPECT_GT(m.area(), 0.0) << name;
  }
  // elephant.off declares 2775 vertices and 5558 triangles: counts must match the header.
  if (fs::exists(dir + "/elephant.off")) {
    const auto e = io::readOff(dir + "/elephant.off");
    std::ifstream is(dir + "/elephant.off");
    std::string kw;
    std::size_t nv = 0, nf = 0;
    is >> kw >> nv >> nf;
    EXPECT_EQ(e.numVertices(), nv);
    EXPECT_EQ(e.numFaces(), nf);
  }
  // cube_poly.off: a closed cube of quads/polygons with side 2 → area 24 after fan triangulation.
  if (fs::exists(dir + "/cube_poly.off")) {
    const auto c = io::readOff(dir + "/cube_poly.off");
    Eigen::Vector3f lo = c.vertices[0], hi = c.vertices[0];
    for (const auto& v : c.vertices) lo = lo.cwiseMin(v), hi = hi.cwiseMax(v);
    const Eigen::Vector3d s = (hi - lo).cast<double>();
    EXPECT_NEAR(c.area(), 2 * (s.x() * s.y() + s.y() * s.z() + s.x() * s.z()), 1e-4);
  }
}
