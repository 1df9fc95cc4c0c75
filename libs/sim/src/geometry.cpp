#include "obm/sim/geometry.hpp"

#include <array>
#include <cmath>
#include <map>

#include "obm/core/errors.hpp"
#include "obm/sim/random.hpp"

namespace obm::sim {

namespace {
// Reflectivities are rough values for a 905 nm LiDAR (asphalt dark, concrete and painted walls
// bright, glass and tyres nearly black); `dropout` models specular or absorbing surfaces that
// often return nothing, `pass_through` surfaces the beam partly penetrates (foliage).
const MaterialProperties kMaterials[] = {
    {"default", 0.40f, 0.00f, 0.00f, {170, 170, 170}},
    {"road", 0.20f, 0.00f, 0.00f, {90, 90, 95}},
    {"sidewalk", 0.28f, 0.00f, 0.00f, {175, 170, 160}},
    {"kerb", 0.35f, 0.00f, 0.00f, {200, 200, 195}},
    {"grass", 0.30f, 0.00f, 0.00f, {110, 150, 80}},
    {"facade", 0.45f, 0.00f, 0.00f, {215, 195, 165}},
    {"glass", 0.10f, 0.50f, 0.00f, {120, 160, 190}},
    {"roof", 0.22f, 0.00f, 0.00f, {160, 80, 60}},
    {"balcony", 0.40f, 0.00f, 0.00f, {190, 190, 200}},
    {"car_paint", 0.35f, 0.05f, 0.00f, {60, 90, 170}},
    {"car_glass", 0.08f, 0.60f, 0.00f, {40, 50, 60}},
    {"tyre", 0.05f, 0.10f, 0.00f, {30, 30, 30}},
    {"metal", 0.60f, 0.00f, 0.00f, {150, 150, 160}},
    {"tree_trunk", 0.30f, 0.00f, 0.00f, {110, 80, 50}},
    {"foliage", 0.35f, 0.05f, 0.35f, {60, 130, 50}},
    {"wall", 0.45f, 0.00f, 0.00f, {225, 220, 210}},
    {"floor", 0.30f, 0.00f, 0.00f, {150, 120, 90}},
    {"ceiling", 0.60f, 0.00f, 0.00f, {240, 240, 240}},
    {"door", 0.40f, 0.00f, 0.00f, {160, 110, 70}},
    {"wood", 0.35f, 0.00f, 0.00f, {180, 140, 90}},
    {"fabric", 0.20f, 0.00f, 0.00f, {90, 60, 110}},
    {"plastic", 0.50f, 0.00f, 0.00f, {200, 60, 50}},
    {"clutter", 0.45f, 0.00f, 0.00f, {230, 180, 60}},
};
static_assert(sizeof(kMaterials) / sizeof(kMaterials[0]) ==
                  static_cast<std::size_t>(Material::Count),
              "one entry per Material");
}  // namespace

// Corner index bits of a box: x = 1, y = 2, z = 4. Quads counter-clockwise seen from outside.
static const int kBoxQuads[6][4] = {{0, 2, 3, 1}, {4, 5, 7, 6}, {0, 1, 5, 4},
                                    {2, 6, 7, 3}, {0, 4, 6, 2}, {1, 3, 7, 5}};

const MaterialProperties& materialProperties(Material m) {
  const auto i = static_cast<std::size_t>(m);
  return i < static_cast<std::size_t>(Material::Count) ? kMaterials[i] : kMaterials[0];
}

// ---------------------------------------------------------------------------------------------
// SceneMesh

void SceneMesh::append(const TriangleMesh& other, Material m) {
  mesh.append(other);
  materials.insert(materials.end(), other.faces.size(), m);
}

void SceneMesh::append(const SceneMesh& other) {
  mesh.append(other.mesh);
  materials.insert(materials.end(), other.materials.begin(), other.materials.end());
}

void SceneMesh::transform(const Eigen::Isometry3d& T) {
  mesh.transform(T);
}

void SceneMesh::validate() const {
  mesh.validate();
  if (materials.size() != mesh.faces.size())
    throw ContractError("scene mesh '" + mesh.name + "': " + std::to_string(materials.size()) +
                        " materials for " + std::to_string(mesh.faces.size()) + " faces");
}

Eigen::AlignedBox3d SceneMesh::bounds() const {
  Eigen::AlignedBox3d b;
  for (const auto& v : mesh.vertices) b.extend(v.cast<double>());
  return b;
}

// ---------------------------------------------------------------------------------------------
// MeshBuilder

int MeshBuilder::vertex(const Eigen::Vector3d& p) {
  out_.mesh.vertices.push_back(p.cast<float>());
  return static_cast<int>(out_.mesh.vertices.size() - 1);
}

void MeshBuilder::triangle(const Eigen::Vector3d& a, const Eigen::Vector3d& b,
                           const Eigen::Vector3d& c, Material m) {
  const int ia = vertex(a), ib = vertex(b), ic = vertex(c);
  out_.mesh.faces.emplace_back(ia, ib, ic);
  out_.materials.push_back(m);
}

void MeshBuilder::quad(const Eigen::Vector3d& a, const Eigen::Vector3d& b, const Eigen::Vector3d& c,
                       const Eigen::Vector3d& d, Material m) {
  const int ia = vertex(a), ib = vertex(b), ic = vertex(c), id = vertex(d);
  out_.mesh.faces.emplace_back(ia, ib, ic);
  out_.mesh.faces.emplace_back(ia, ic, id);
  out_.materials.push_back(m);
  out_.materials.push_back(m);
}

void MeshBuilder::box(const Eigen::Isometry3d& T, const Eigen::Vector3d& size, Material m) {
  const Eigen::Vector3d h = 0.5 * size;
  int v[8];
  for (int i = 0; i < 8; ++i) {
    const Eigen::Vector3d p((i & 1) ? h.x() : -h.x(), (i & 2) ? h.y() : -h.y(),
                            (i & 4) ? h.z() : -h.z());
    v[i] = vertex(T * p);
  }
  for (const auto& q : kBoxQuads) {
    out_.mesh.faces.emplace_back(v[q[0]], v[q[1]], v[q[2]]);
    out_.mesh.faces.emplace_back(v[q[0]], v[q[2]], v[q[3]]);
    out_.materials.push_back(m);
    out_.materials.push_back(m);
  }
}

void MeshBuilder::hexahedron(const Eigen::Vector3d (&c)[8], Material m) {
  int v[8];
  for (int i = 0; i < 8; ++i) v[i] = vertex(c[i]);
  for (const auto& q : kBoxQuads) {
    out_.mesh.faces.emplace_back(v[q[0]], v[q[1]], v[q[2]]);
    out_.mesh.faces.emplace_back(v[q[0]], v[q[2]], v[q[3]]);
    out_.materials.push_back(m);
    out_.materials.push_back(m);
  }
}

void MeshBuilder::aabb(const Eigen::Vector3d& lo, const Eigen::Vector3d& hi, Material m) {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.translation() = 0.5 * (lo + hi);
  box(T, hi - lo, m);
}

namespace {
double cross2(const Eigen::Vector2d& a, const Eigen::Vector2d& b) {
  return a.x() * b.y() - a.y() * b.x();
}

// Ear clipping of a simple counter-clockwise polygon; returns index triples (CCW).
std::vector<std::array<int, 3>> triangulate(const std::vector<Eigen::Vector2d>& poly) {
  std::vector<std::array<int, 3>> tris;
  std::vector<int> idx(poly.size());
  for (std::size_t i = 0; i < poly.size(); ++i) idx[i] = static_cast<int>(i);
  std::size_t guard = 0;
  while (idx.size() > 3 && guard++ < 10 * poly.size() * poly.size()) {
    bool clipped = false;
    for (std::size_t i = 0; i < idx.size(); ++i) {
      const int a = idx[(i + idx.size() - 1) % idx.size()], b = idx[i],
                c = idx[(i + 1) % idx.size()];
      const Eigen::Vector2d &A = poly[a], &B = poly[b], &C = poly[c];
      if (cross2(B - A, C - B) <= 1e-12) continue;  // reflex or degenerate corner
      bool inside = false;
      for (int j : idx) {
        if (j == a || j == b || j == c) continue;
        const Eigen::Vector2d& P = poly[j];
        if (cross2(B - A, P - A) >= 0 && cross2(C - B, P - B) >= 0 && cross2(A - C, P - C) >= 0) {
          inside = true;
          break;
        }
      }
      if (inside) continue;
      tris.push_back({a, b, c});
      idx.erase(idx.begin() + static_cast<std::ptrdiff_t>(i));
      clipped = true;
      break;
    }
    if (!clipped) break;  // not simple: give up on the rest (fan below)
  }
  for (std::size_t i = 1; i + 1 < idx.size(); ++i) tris.push_back({idx[0], idx[i], idx[i + 1]});
  return tris;
}
}  // namespace

void MeshBuilder::prism(const Eigen::Isometry3d& T, const std::vector<Eigen::Vector2d>& polygon,
                        double z0, double z1, Material m) {
  const std::size_t n = polygon.size();
  OBM_ASSERT(n >= 3, "prism needs a polygon of at least 3 vertices");
  std::vector<int> bot(n), top(n);
  for (std::size_t i = 0; i < n; ++i) {
    bot[i] = vertex(T * Eigen::Vector3d(polygon[i].x(), polygon[i].y(), z0));
    top[i] = vertex(T * Eigen::Vector3d(polygon[i].x(), polygon[i].y(), z1));
  }
  auto& F = out_.mesh.faces;
  for (std::size_t i = 0; i < n; ++i) {
    const std::size_t j = (i + 1) % n;
    F.emplace_back(bot[i], bot[j], top[j]);
    F.emplace_back(bot[i], top[j], top[i]);
    out_.materials.push_back(m);
    out_.materials.push_back(m);
  }
  for (const auto& t : triangulate(polygon)) {
    F.emplace_back(top[t[0]], top[t[1]], top[t[2]]);
    F.emplace_back(bot[t[0]], bot[t[2]], bot[t[1]]);
    out_.materials.push_back(m);
    out_.materials.push_back(m);
  }
}

void MeshBuilder::cylinder(const Eigen::Isometry3d& T, double r_bottom, double r_top, double height,
                           int segments, Material m) {
  OBM_ASSERT(segments >= 3, "cylinder needs at least 3 segments");
  const int n = segments;
  std::vector<int> bot(n), top(n);
  for (int i = 0; i < n; ++i) {
    const double a = 2.0 * M_PI * i / n;
    bot[i] = vertex(T * Eigen::Vector3d(r_bottom * std::cos(a), r_bottom * std::sin(a), 0.0));
    if (r_top > 0.0)
      top[i] = vertex(T * Eigen::Vector3d(r_top * std::cos(a), r_top * std::sin(a), height));
  }
  const int cb = vertex(T * Eigen::Vector3d(0, 0, 0));
  const int ct = vertex(T * Eigen::Vector3d(0, 0, height));
  auto& F = out_.mesh.faces;
  for (int i = 0; i < n; ++i) {
    const int j = (i + 1) % n;
    if (r_top > 0.0) {
      F.emplace_back(bot[i], bot[j], top[j]);
      F.emplace_back(bot[i], top[j], top[i]);
      F.emplace_back(ct, top[i], top[j]);
      out_.materials.insert(out_.materials.end(), 3, m);
    } else {
      F.emplace_back(bot[i], bot[j], ct);
      out_.materials.push_back(m);
    }
    F.emplace_back(cb, bot[j], bot[i]);
    out_.materials.push_back(m);
  }
}

void MeshBuilder::blob(const Eigen::Isometry3d& T, const Eigen::Vector3d& radii, int subdivisions,
                       double jitter, std::uint64_t seed, Material m) {
  // Icosahedron (vertices on the unit sphere), then 1-to-4 subdivision with a midpoint cache.
  const double t = (1.0 + std::sqrt(5.0)) / 2.0;
  std::vector<Eigen::Vector3d> V = {{-1, t, 0}, {1, t, 0}, {-1, -t, 0}, {1, -t, 0},
                                    {0, -1, t}, {0, 1, t}, {0, -1, -t}, {0, 1, -t},
                                    {t, 0, -1}, {t, 0, 1}, {-t, 0, -1}, {-t, 0, 1}};
  for (auto& v : V) v.normalize();
  std::vector<Eigen::Vector3i> Fs = {{0, 11, 5}, {0, 5, 1},  {0, 1, 7},   {0, 7, 10}, {0, 10, 11},
                                     {1, 5, 9},  {5, 11, 4}, {11, 10, 2}, {10, 7, 6}, {7, 1, 8},
                                     {3, 9, 4},  {3, 4, 2},  {3, 2, 6},   {3, 6, 8},  {3, 8, 9},
                                     {4, 9, 5},  {2, 4, 11}, {6, 2, 10},  {8, 6, 7},  {9, 8, 1}};
  for (int s = 0; s < subdivisions; ++s) {
    std::map<std::pair<int, int>, int> mid;
    auto midpoint = [&](int a, int b) {
      const auto key = std::make_pair(std::min(a, b), std::max(a, b));
      const auto it = mid.find(key);
      if (it != mid.end()) return it->second;
      V.push_back((V[a] + V[b]).normalized());
      const int id = static_cast<int>(V.size() - 1);
      mid.emplace(key, id);
      return id;
    };
    std::vector<Eigen::Vector3i> next;
    next.reserve(Fs.size() * 4);
    for (const auto& f : Fs) {
      const int a = midpoint(f[0], f[1]), b = midpoint(f[1], f[2]), c = midpoint(f[2], f[0]);
      next.emplace_back(f[0], a, c);
      next.emplace_back(f[1], b, a);
      next.emplace_back(f[2], c, b);
      next.emplace_back(a, b, c);
    }
    Fs.swap(next);
  }
  Rng rng(seed);
  const int base = static_cast<int>(out_.mesh.vertices.size());
  for (const auto& v : V) {
    const double r = 1.0 + jitter * (2.0 * rng.uniform() - 1.0);
    vertex(T * Eigen::Vector3d(v.cwiseProduct(radii) * r));
  }
  for (const auto& f : Fs) {
    out_.mesh.faces.emplace_back(f.array() + base);
    out_.materials.push_back(m);
  }
}

void MeshBuilder::heightField(double x0, double y0, double x1, double y1, double res,
                              const std::function<double(double, double)>& h, Material m) {
  heightField(x0, y0, x1, y1, res, h, [m](double, double) { return m; });
}

void MeshBuilder::heightField(double x0, double y0, double x1, double y1, double res,
                              const std::function<double(double, double)>& h,
                              const std::function<Material(double, double)>& material) {
  OBM_ASSERT(res > 0 && x1 > x0 && y1 > y0, "height field needs a positive extent and cell");
  const int nx = std::max(1, static_cast<int>(std::ceil((x1 - x0) / res)));
  const int ny = std::max(1, static_cast<int>(std::ceil((y1 - y0) / res)));
  const double dx = (x1 - x0) / nx, dy = (y1 - y0) / ny;
  const int base = static_cast<int>(out_.mesh.vertices.size());
  out_.mesh.vertices.reserve(out_.mesh.vertices.size() +
                             static_cast<std::size_t>((nx + 1) * (ny + 1)));
  for (int j = 0; j <= ny; ++j)
    for (int i = 0; i <= nx; ++i) {
      const double x = x0 + i * dx, y = y0 + j * dy;
      vertex(Eigen::Vector3d(x, y, h(x, y)));
    }
  auto id = [&](int i, int j) { return base + j * (nx + 1) + i; };
  for (int j = 0; j < ny; ++j)
    for (int i = 0; i < nx; ++i) {
      const Material m = material(x0 + (i + 0.5) * dx, y0 + (j + 0.5) * dy);
      out_.mesh.faces.emplace_back(id(i, j), id(i + 1, j), id(i + 1, j + 1));
      out_.mesh.faces.emplace_back(id(i, j), id(i + 1, j + 1), id(i, j + 1));
      out_.materials.push_back(m);
      out_.materials.push_back(m);
    }
}

}  // namespace obm::sim
