#pragma once
/// \file object_set.hpp
/// The object data set of the object-level protocols, built from triangle meshes (the CGAL sample
/// meshes that Debian ships, or any OFF/PLY/OBJ collection): surface-sampled, normalised to the
/// unit sphere, and split by name hash into train / validation / an unseen test group.
#include <cstdint>
#include <string>
#include <vector>

#include "obm/core/mesh.hpp"
#include "obm/core/point_cloud.hpp"
#include "obm/obmnet/data.hpp"

namespace obm {

class ConfigNode;

namespace obmnet {

struct ObjectSetOptions {
  int surface_points = 2048;    ///< points sampled per mesh (area-weighted), as ModelNet40's 2048
  int keep_points = 1024;       ///< the first points kept, as RIENet keeps the first 1024
  double val_fraction = 0.15;   ///< share of names in the validation split
  double test_fraction = 0.25;  ///< share of names in the unseen test split
  std::uint64_t seed = 0;       ///< surface sampling seed (combined with each mesh's name)
  /// > 0: also this many reference samples of every surface (ObjectSet::*_reference), in the
  /// frame of the object's points (same normalisation), for scoring registrations up to the
  /// object's symmetries (obm::eval::SurfaceErrorScorer). Benchmarks only; the points the pairs
  /// are cut from do not change.
  int reference_points = 0;

  static ObjectSetOptions load(const ConfigNode& node);
};

struct ObjectSet {
  std::vector<PointCloud> train, val, test;  ///< frame_id holds the object's name
  /// With ObjectSetOptions::reference_points > 0, one denser sample per object of the split
  /// above (same order, same frame); else empty.
  std::vector<PointCloud> train_reference, val_reference, test_reference;
};

/// Samples every mesh (independently of the order of `meshes`), normalises it to the unit sphere
/// and assigns it to its split. Meshes without area are skipped with a warning.
ObjectSet buildObjectSet(const std::vector<TriangleMesh>& meshes, const ObjectSetOptions& options);

}  // namespace obmnet
}  // namespace obm
