#pragma once
/// \file geometry.hpp
/// Scene geometry as the simulator builds it: a triangle mesh whose faces carry a material, and a
/// builder of the primitives the procedural scenes are made of (boxes, prisms, cylinders, blobs,
/// height fields). Every primitive is closed or one-sided with counter-clockwise faces seen from
/// outside, so the geometric normal points away from the solid.
#include <Eigen/Core>
#include <Eigen/Geometry>
#include <cstdint>
#include <functional>
#include <string>
#include <vector>

#include "obm/core/mesh.hpp"

namespace obm::sim {

/// Surface classes. They set the LiDAR reflectivity, how often a ray passes through or is lost,
/// and the colour in pictures.
enum class Material : std::uint8_t {
  Default = 0,
  Road,
  Sidewalk,
  Kerb,
  Grass,
  Facade,
  Glass,
  Roof,
  Balcony,
  CarPaint,
  CarGlass,
  Tyre,
  Metal,
  TreeTrunk,
  Foliage,
  Wall,
  Floor,
  Ceiling,
  Door,
  Wood,
  Fabric,
  Plastic,
  Clutter,
  Count
};

/// Per-material sensor behaviour and display colour.
struct MaterialProperties {
  const char* name;
  float reflectivity;   ///< LiDAR return strength at normal incidence, [0, 1]
  float dropout;        ///< extra probability that a return is lost (glass, dark paint), [0, 1]
  float pass_through;   ///< probability that a ray continues through (foliage, glass), [0, 1]
  std::uint8_t rgb[3];  ///< colour in pictures
};

/// Table lookup; never fails (unknown values map to Default).
const MaterialProperties& materialProperties(Material m);

/// A triangle mesh with one material per face (the simulator's scene representation).
struct SceneMesh {
  TriangleMesh mesh;
  std::vector<Material> materials;  ///< one per face of `mesh`

  std::size_t numFaces() const noexcept { return mesh.faces.size(); }
  /// Appends a mesh, all of whose faces get `m`.
  void append(const TriangleMesh& other, Material m);
  /// Appends another scene mesh (materials kept).
  void append(const SceneMesh& other);
  /// Applies p ← T·p.
  void transform(const Eigen::Isometry3d& T);
  /// Throws ContractError if the material list does not match the faces or an index is invalid.
  void validate() const;
  /// Axis-aligned bounds of the vertices (empty box when there are none).
  Eigen::AlignedBox3d bounds() const;
};

/// Appends primitives to a SceneMesh. All sizes in metres; poses are T_world_primitive.
class MeshBuilder {
 public:
  explicit MeshBuilder(SceneMesh& out) : out_(out) {}

  /// One triangle (counter-clockwise seen from the side its normal points to).
  void triangle(const Eigen::Vector3d& a, const Eigen::Vector3d& b, const Eigen::Vector3d& c,
                Material m);
  /// A planar quad a-b-c-d (counter-clockwise seen from the front), as two triangles.
  void quad(const Eigen::Vector3d& a, const Eigen::Vector3d& b, const Eigen::Vector3d& c,
            const Eigen::Vector3d& d, Material m);
  /// Closed box of the given full size, centred at the origin of `T`.
  void box(const Eigen::Isometry3d& T, const Eigen::Vector3d& size, Material m);
  /// Closed hexahedron from 8 corners indexed like a box's (bit 0: +x, bit 1: +y, bit 2: +z),
  /// e.g. a kerb stone whose top follows the terrain.
  void hexahedron(const Eigen::Vector3d (&corners)[8], Material m);
  /// Axis-aligned closed box between two corners.
  void aabb(const Eigen::Vector3d& lo, const Eigen::Vector3d& hi, Material m);
  /// Closed prism: a convex or simple counter-clockwise polygon in the x-y plane of `T`,
  /// extruded from z0 to z1.
  void prism(const Eigen::Isometry3d& T, const std::vector<Eigen::Vector2d>& polygon, double z0,
             double z1, Material m);
  /// Closed cylinder of `segments` sides along +z of `T`, from z = 0 to `height`, radii at the
  /// bottom and top (a cone when r_top = 0).
  void cylinder(const Eigen::Isometry3d& T, double r_bottom, double r_top, double height,
                int segments, Material m);
  /// Closed ellipsoid blob (subdivided icosahedron) with radii `radii`; `jitter` ∈ [0, 1) moves
  /// each vertex radially by up to that fraction (seeded by `seed`) so foliage looks irregular.
  void blob(const Eigen::Isometry3d& T, const Eigen::Vector3d& radii, int subdivisions,
            double jitter, std::uint64_t seed, Material m);
  /// Height field z = h(x, y) over [x0, x1]×[y0, y1] on a regular grid with cell `res`, facing +z.
  void heightField(double x0, double y0, double x1, double y1, double res,
                   const std::function<double(double, double)>& h, Material m);
  /// Same with a material chosen per cell (centre coordinates).
  void heightField(double x0, double y0, double x1, double y1, double res,
                   const std::function<double(double, double)>& h,
                   const std::function<Material(double, double)>& material);

  SceneMesh& mesh() { return out_; }

 private:
  int vertex(const Eigen::Vector3d& p);
  SceneMesh& out_;
};

}  // namespace obm::sim
