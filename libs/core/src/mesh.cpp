#include "obm/core/mesh.hpp"

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>

#include "obm/core/errors.hpp"

namespace obm {

void TriangleMesh::validate() const {
  const int n = static_cast<int>(vertices.size());
  for (std::size_t f = 0; f < faces.size(); ++f) {
    const auto& F = faces[f];
    if (F.minCoeff() < 0 || F.maxCoeff() >= n)
      throw ContractError("mesh '" + name + "': face " + std::to_string(f) +
                          " refers to a vertex outside [0, " + std::to_string(n) + ")");
  }
}

namespace {
double triangleArea(const TriangleMesh& m, const Eigen::Vector3i& F) {
  const Eigen::Vector3d a = m.vertices[static_cast<std::size_t>(F[0])].cast<double>();
  const Eigen::Vector3d b = m.vertices[static_cast<std::size_t>(F[1])].cast<double>();
  const Eigen::Vector3d c = m.vertices[static_cast<std::size_t>(F[2])].cast<double>();
  return 0.5 * (b - a).cross(c - a).norm();
}
}  // namespace

double TriangleMesh::area() const {
  double s = 0.0;
  for (const auto& F : faces) s += triangleArea(*this, F);
  return s;
}

void TriangleMesh::append(const TriangleMesh& other) {
  const int offset = static_cast<int>(vertices.size());
  vertices.insert(vertices.end(), other.vertices.begin(), other.vertices.end());
  faces.reserve(faces.size() + other.faces.size());
  for (const auto& F : other.faces) faces.emplace_back(F.array() + offset);
}

void TriangleMesh::transform(const Eigen::Isometry3d& T) {
  const Eigen::Isometry3f Tf = T.cast<float>();
  for (auto& v : vertices) v = Tf * v;
}

PointCloud sampleSurface(const TriangleMesh& mesh, std::size_t n, std::mt19937_64& rng) {
  mesh.validate();
  // Cumulative areas: a triangle is drawn with probability area / total (inverse-CDF sampling).
  std::vector<double> cdf(mesh.faces.size());
  double total = 0.0;
  for (std::size_t f = 0; f < mesh.faces.size(); ++f) {
    total += triangleArea(mesh, mesh.faces[f]);
    cdf[f] = total;
  }
  if (!(total > 0.0)) throw ContractError("mesh '" + mesh.name + "' has no surface area to sample");
  std::uniform_real_distribution<double> U(0.0, 1.0);
  PointCloud out;
  out.frame_id = "object";
  out.reserve(n);
  for (std::size_t i = 0; i < n; ++i) {
    const double r = U(rng) * total;
    auto it = std::upper_bound(cdf.begin(), cdf.end(), r);
    if (it == cdf.end()) --it;
    const auto& F = mesh.faces[static_cast<std::size_t>(it - cdf.begin())];
    // Uniform point in a triangle: (1 − √u, √u(1 − v), √u·v) barycentric weights.
    const double su = std::sqrt(U(rng)), v = U(rng);
    const Eigen::Vector3d a = mesh.vertices[static_cast<std::size_t>(F[0])].cast<double>();
    const Eigen::Vector3d b = mesh.vertices[static_cast<std::size_t>(F[1])].cast<double>();
    const Eigen::Vector3d c = mesh.vertices[static_cast<std::size_t>(F[2])].cast<double>();
    out.points.push_back(((1.0 - su) * a + su * (1.0 - v) * b + su * v * c).cast<float>());
  }
  return out;
}

void normalizeToSphere(PointCloud& cloud, float radius) {
  if (cloud.empty()) return;
  const Vector3f c = cloud.centroid();
  float r = 0.f;
  for (auto& p : cloud.points) {
    p -= c;
    r = std::max(r, p.norm());
  }
  if (r > 0.f)
    for (auto& p : cloud.points) p *= radius / r;
}

}  // namespace obm
