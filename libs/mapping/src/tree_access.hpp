#pragma once
// Private: the OctoMap trees behind OccupancyMap (shared by the map and its top-view writer).
#include <octomap/ColorOcTree.h>
#include <octomap/OcTree.h>

#include <cstddef>
#include <memory>

#include "batch_update.hpp"
#include "obm/mapping/occupancy_map.hpp"

namespace obm::mapping {

struct OccupancyMap::Impl {
  Impl(const MappingParams& p, MapKind k);

  MappingParams params;
  MapKind kind;
  std::unique_ptr<octomap::OcTree> occ;         ///< set when kind == Occupancy
  std::unique_ptr<octomap::ColorOcTree> color;  ///< set when kind == Color
  /// Inner nodes lag behind the leaves after lazy insertions.
  bool inner_dirty = false;
  std::size_t num_insertions = 0;
  std::size_t num_rays = 0;
  std::size_t insertions_since_prune = 0;
  detail::BatchScratch scratch;  ///< buffers of the batch update, reused across insertions

  /// Brings inner nodes (occupancy, and colour for a ColorOcTree) up to date.
  void ensureInnerUpdated();

  /// Calls `f` on the concrete tree (OcTree& or ColorOcTree&) and returns its result.
  template <typename F>
  decltype(auto) visit(F&& f) {
    if (kind == MapKind::Color) return f(*color);
    return f(*occ);
  }
};

}  // namespace obm::mapping
