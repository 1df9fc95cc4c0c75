#pragma once
/// \file mesh.hpp
/// A triangle mesh (the scene and object type shared by the simulator, the object data set of the
/// network, and the mesh readers in obm::io), and area-weighted surface sampling.
#include <Eigen/Core>
#include <cstdint>
#include <random>
#include <string>
#include <vector>

#include "obm/core/point_cloud.hpp"

namespace obm {

struct TriangleMesh {
  std::vector<Eigen::Vector3f> vertices;  ///< [m] or model units
  std::vector<Eigen::Vector3i> faces;     ///< vertex indices, counter-clockwise seen from outside
  std::string name;                       ///< e.g. the file stem

  std::size_t numVertices() const noexcept { return vertices.size(); }
  std::size_t numFaces() const noexcept { return faces.size(); }
  bool empty() const noexcept { return faces.empty(); }

  /// Throws ContractError naming the mesh when a face index is out of range.
  void validate() const;
  /// Total surface area (sum of triangle areas).
  double area() const;
  /// Appends `other` (indices shifted).
  void append(const TriangleMesh& other);
  /// Applies p ← T·p to every vertex.
  void transform(const Eigen::Isometry3d& T);
};

/// Draws `n` points uniformly on the surface (triangle chosen with probability ∝ area, then a
/// uniform barycentric point). Deterministic for a given `rng` state. Degenerate (zero-area)
/// triangles are never drawn; throws ContractError if the mesh has no area.
PointCloud sampleSurface(const TriangleMesh& mesh, std::size_t n, std::mt19937_64& rng);

/// Centres a cloud on its centroid and scales it so the farthest point is at distance `radius`
/// (ModelNet40's unit-sphere normalisation). No-op on an empty cloud.
void normalizeToSphere(PointCloud& cloud, float radius = 1.0f);

}  // namespace obm
