#pragma once
/// \file mapping_params.hpp
/// Parameters of the OctoMap occupancy map (Hornung et al., "OctoMap: an efficient probabilistic 3D
/// mapping framework based on octrees", Autonomous Robots 2013). Probabilities enter OctoMap's
/// log-odds update L(n | z_1:t) = max(min(L(n | z_1:t-1) + L(n | z_t), l_max), l_min) (paper
/// eq. 3 with the clamping of eq. 4): `prob_hit` / `prob_miss` give L(n | z_t) for a beam end point
/// and for a cell the beam crosses, `clamping_min` / `clamping_max` give l_min / l_max.
#include <cstddef>

namespace obm {
class ConfigNode;
}

namespace obm::mapping {

/// Everything OccupancyMap needs; defaults are tuned for real-time mapping of a 10 Hz 64-beam
/// LiDAR on one core (see docs/benchmarks.md, "Mapping (OctoMap)").
struct MappingParams {
  double resolution = 0.2;  ///< [m] edge of a leaf voxel

  /// [m] beams are cast at most this far: a longer beam clears the cells up to max_range and marks
  /// no end point (OctoMap's `maxrange`); <= 0 means unlimited.
  double max_range = 60.0;
  /// [m] points nearer than this to the sensor are dropped first (returns from the vehicle).
  double min_range = 0.0;

  double prob_hit = 0.7;             ///< P(occupied | beam ends in the cell), > 0.5
  double prob_miss = 0.4;            ///< P(occupied | beam crosses the cell), < 0.5
  double clamping_min = 0.1192;      ///< lower clamp of the occupancy probability
  double clamping_max = 0.971;       ///< upper clamp of the occupancy probability
  double occupancy_threshold = 0.5;  ///< a cell is occupied above this probability

  /// [m] voxel-grid down-sampling of each cloud in the sensor frame before ray casting (one ray per
  /// voxel centroid, which also averages range noise); 0 disables it. At most `resolution`:
  /// coarser pre-filtering would leave holes in surfaces. Off by default: with `discretize` the
  /// beams are already one per end cell, and the filter costs about what it saves
  /// (docs/benchmarks.md).
  double prefilter_voxel = 0.0;
  /// Discretise the end points on the map grid first so each end cell is ray-cast once (OctoMap's
  /// `discretize` / computeDiscreteUpdate); slightly different free space than one ray per point.
  bool discretize = true;
  /// Update the cells in octree (Morton) order from a sorted array instead of OctoMap's hash-set
  /// order: the same cells get the same updates as with OctoMap's insertPointCloud, 2–3× faster.
  /// false = call insertPointCloud itself (for comparison).
  bool batch_update = true;
  /// Skip updating inner nodes during insertion (OctoMap's `lazy_eval`); the map updates them once
  /// before any query, pruning or export, so results are the same.
  bool lazy_update = true;
  /// Prune (merge identical children) after every this many insertions to bound memory; 0 = only
  /// when asked or on export.
  std::size_t prune_every = 20;

  /// Reads the keys of a `mapping:` section (all optional; the names above). Throws ConfigError
  /// naming file and key for a wrong type, an unknown key or an out-of-range value.
  static MappingParams load(const ConfigNode& node);

  /// Throws ConfigError naming the first field out of range (resolution <= 0, prob_hit <= 0.5,
  /// ...).
  void validate() const;
};

}  // namespace obm::mapping
