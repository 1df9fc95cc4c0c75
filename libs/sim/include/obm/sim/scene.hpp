#pragma once
/// \file scene.hpp
/// A scene ready for ray casting: the SceneMesh plus an Intel Embree 3 acceleration structure
/// (kept private: no Embree header is needed to use this class).
#include <Eigen/Core>
#include <Eigen/Geometry>
#include <cmath>
#include <cstdint>
#include <limits>
#include <memory>
#include <vector>

#include "obm/sim/geometry.hpp"

namespace obm::sim {

/// Result of one ray.
struct RayHit {
  float range = std::numeric_limits<float>::infinity();  ///< ray parameter t of the hit (∞: miss)
  float cos_incidence = 0.f;  ///< |cos| of the angle between the ray and the surface normal
  Eigen::Vector3f normal = Eigen::Vector3f::Zero();  ///< unit geometric normal facing the ray
  Material material = Material::Default;
  std::uint32_t face = std::numeric_limits<std::uint32_t>::max();  ///< face index in the mesh
  bool hit() const noexcept { return std::isfinite(range); }
};

/// Options of the acceleration structure.
struct RaycastSceneOptions {
  /// Embree's robust mode: no ray slips through the shared edge of two triangles (slightly
  /// slower). Needed for watertight height fields and exact-range tests.
  bool robust = true;
  /// High-quality BVH (spatial splits): slower to build, faster to traverse — right for static
  /// scenes cast millions of rays against.
  bool high_quality = true;
  /// Threads Embree may use to build the BVH (0 = all).
  int build_threads = 0;
};

/// An immutable ray-castable scene. Thread-safe for concurrent queries after construction.
class RaycastScene {
 public:
  /// Builds the BVH. Throws ContractError on an empty or invalid mesh, Error if Embree fails.
  explicit RaycastScene(SceneMesh mesh, const RaycastSceneOptions& options = {});
  ~RaycastScene();
  RaycastScene(RaycastScene&&) noexcept;
  RaycastScene& operator=(RaycastScene&&) noexcept;
  RaycastScene(const RaycastScene&) = delete;
  RaycastScene& operator=(const RaycastScene&) = delete;

  const SceneMesh& mesh() const;
  /// Axis-aligned bounds of the geometry.
  const Eigen::AlignedBox3d& bounds() const;

  /// Casts one ray from `origin` along `direction` (any length: `range` is in units of it)
  /// and returns the nearest hit with t in [t_min, t_max].
  RayHit intersect(const Eigen::Vector3f& origin, const Eigen::Vector3f& direction,
                   float t_min = 0.f, float t_max = std::numeric_limits<float>::infinity()) const;

  /// Batched version (Embree 16-wide packets); `hits` is resized to the number of rays.
  void intersect(const std::vector<Eigen::Vector3f>& origins,
                 const std::vector<Eigen::Vector3f>& directions, float t_min, float t_max,
                 std::vector<RayHit>& hits) const;

  /// True when the segment from `origin` along `direction` with t in [t_min, t_max] hits
  /// anything (shadow / visibility test).
  bool occluded(const Eigen::Vector3f& origin, const Eigen::Vector3f& direction, float t_min,
                float t_max) const;

  /// Opaque implementation (Embree handles); used by the sensor models inside the library.
  struct Impl;
  const Impl& impl() const { return *impl_; }

 private:
  std::unique_ptr<Impl> impl_;
};

}  // namespace obm::sim
