#include <algorithm>
#include <cmath>

#include "obm/core/errors.hpp"
#include "obm/io/mesh_io.hpp"
#include "obm/sim/scenes.hpp"

namespace obm::sim {

HeightMap::HeightMap(double x0, double y0, double resolution, int nx, int ny, double fill)
    : x0_(x0),
      y0_(y0),
      res_(resolution),
      nx_(nx),
      ny_(ny),
      data_(static_cast<std::size_t>(nx) * static_cast<std::size_t>(ny), static_cast<float>(fill)) {
  OBM_ASSERT(resolution > 0 && nx > 0 && ny > 0, "height map needs a positive size");
}

double HeightMap::at(double x, double y) const {
  if (data_.empty()) return 0.0;
  const double fx = std::clamp((x - x0_) / res_, 0.0, static_cast<double>(nx_ - 1));
  const double fy = std::clamp((y - y0_) / res_, 0.0, static_cast<double>(ny_ - 1));
  const int i = std::min(nx_ - 2 < 0 ? 0 : nx_ - 2, static_cast<int>(fx));
  const int j = std::min(ny_ - 2 < 0 ? 0 : ny_ - 2, static_cast<int>(fy));
  const int i1 = std::min(i + 1, nx_ - 1), j1 = std::min(j + 1, ny_ - 1);
  const double a = fx - i, b = fy - j;
  return (1 - a) * (1 - b) * node(i, j) + a * (1 - b) * node(i1, j) + (1 - a) * b * node(i, j1) +
         a * b * node(i1, j1);
}

GeneratedScene loadMeshScene(const std::string& file, double scale,
                             const Eigen::Isometry3d& T_world_mesh) {
  if (!(scale > 0.0)) throw ConfigError("scene mesh '" + file + "': scale must be positive");
  TriangleMesh m = io::readMesh(file);
  if (m.faces.empty()) throw FormatError(file, 0, "the mesh has no triangles to ray cast");
  m.validate();
  for (auto& v : m.vertices) v *= static_cast<float>(scale);
  m.transform(T_world_mesh);
  GeneratedScene g;
  g.mesh.append(m, Material::Default);
  g.mesh.mesh.name = m.name;
  // A sensor may ride up to 5 m above the mesh's highest point (a flat floor has no height).
  g.bounds = g.mesh.bounds();
  g.bounds.max().z() += 5.0;
  // Ground: the lowest vertex (a flat floor), good enough for pictures and walk heights.
  g.ground = HeightMap(g.bounds.min().x(), g.bounds.min().y(), 1.0, 2, 2, g.bounds.min().z());
  g.description = "mesh '" + file + "': " + std::to_string(m.faces.size()) + " triangles";
  return g;
}

}  // namespace obm::sim
