#pragma once
/// \file occupancy_map.hpp
/// A 3D probabilistic occupancy map over OctoMap's `OcTree` (or `ColorOcTree` for coloured clouds):
/// clouds in their sensor frame are inserted at a pose T_world_sensor by casting a ray from the
/// sensor origin to every point (cells crossed become more likely free, the end cell more likely
/// occupied), and the map is exported as `.bt` (maximum-likelihood, OctoMap's compact binary) or
/// `.ot` (full probabilities, and colours), summarised by MapStats and drawn as a top-view PNG.
///
/// OctoMap stays out of this header (pimpl): consumers link obm::mapping only.
///
/// Thread safety: none. An OccupancyMap must be used from one thread at a time, including its
/// const member functions (they may bring the lazily updated inner nodes up to date). Distinct
/// maps are independent.
#include <Eigen/Core>
#include <cstddef>
#include <cstdint>
#include <functional>
#include <limits>
#include <memory>
#include <string>
#include <vector>

#include "obm/core/point_cloud.hpp"
#include "obm/core/se3.hpp"
#include "obm/mapping/mapping_params.hpp"

namespace obm::mapping {

/// Which tree the map holds.
enum class MapKind {
  Occupancy,  ///< octomap::OcTree: occupancy only
  Color,      ///< octomap::ColorOcTree: occupancy + the averaged RGB of the points in each cell
};

/// State of a location in the map.
enum class CellState { Unknown, Free, Occupied };

/// What one insertion did.
struct InsertResult {
  std::size_t points_in = 0;       ///< points in the given cloud
  std::size_t points_dropped = 0;  ///< non-finite or nearer than min_range
  std::size_t rays = 0;            ///< points handed to the ray caster (after the pre-filter)
  /// beams actually cast: `rays`, or the number of distinct end cells with `discretize` (0 =
  /// unknown: batch_update off with discretize, OctoMap does not report it)
  std::size_t beams = 0;
  double time_ms = 0.0;  ///< [ms] wall time of the insertion
};

/// Size and content of the map. Volumes count leaf voxels (a pruned node of edge s counts s³).
struct MapStats {
  double resolution = 0.0;     ///< [m] leaf edge
  std::size_t num_nodes = 0;   ///< all nodes of the tree (inner + leaves)
  std::size_t num_leaves = 0;  ///< leaf nodes (after the last pruning)
  std::size_t num_occupied_leaves = 0;
  std::size_t num_free_leaves = 0;
  double occupied_volume_m3 = 0.0;  ///< [m³] volume of the occupied leaves
  double free_volume_m3 = 0.0;      ///< [m³] volume of the free leaves
  std::size_t memory_bytes = 0;     ///< OctoMap's estimate of the tree's memory
  /// [m] axis-aligned bounds of the known (free or occupied) space; zero when the map is empty.
  Eigen::Vector3d bbox_min = Eigen::Vector3d::Zero();
  Eigen::Vector3d bbox_max = Eigen::Vector3d::Zero();
  /// [m] bounds of the occupied space only; zero when nothing is occupied.
  Eigen::Vector3d occupied_min = Eigen::Vector3d::Zero();
  Eigen::Vector3d occupied_max = Eigen::Vector3d::Zero();
  std::size_t num_insertions = 0;  ///< clouds inserted since construction / clear()
  std::size_t num_rays = 0;        ///< InsertResult::rays summed since construction / clear()
  bool empty() const noexcept { return num_leaves == 0; }
};

/// Options of the top-view picture.
struct TopViewOptions {
  /// [m] edge of one pixel; 0 = the map resolution. Raised automatically when the picture would
  /// exceed `max_pixels` on a side.
  double pixel_size = 0.0;
  int max_pixels = 4096;  ///< [px] upper bound on width and height
  /// [m] only voxels whose centre z is within [z_min, z_max] are drawn (e.g. below a ceiling).
  double z_min = -std::numeric_limits<double>::infinity();
  double z_max = std::numeric_limits<double>::infinity();
  /// Colour occupied columns with the highest voxel's RGB (ColorOcTree maps only) instead of the
  /// height colour map.
  bool use_voxel_color = false;
};

/// Geometry of a written top view: pixel (col, row) covers x ∈ [x_min + col·s, x_min + (col+1)·s),
/// y ∈ (y_max − (row+1)·s, y_max − row·s] with s = pixel_size (north = +y up, east = +x right).
struct TopViewInfo {
  int width = 0;                    ///< [px]
  int height = 0;                   ///< [px]
  double pixel_size = 0.0;          ///< [m]
  double x_min = 0.0;               ///< [m] world x of the left edge
  double y_max = 0.0;               ///< [m] world y of the top edge
  double z_low = 0.0;               ///< [m] height drawn with the first colour of the map
  double z_high = 0.0;              ///< [m] height drawn with the last colour of the map
  std::size_t occupied_pixels = 0;  ///< columns with an occupied voxel
  std::size_t free_pixels = 0;      ///< columns known free only
};

/// A rendered top view: its geometry and the pixels, row-major from the top-left corner.
struct TopView {
  TopViewInfo info;
  std::vector<std::uint8_t> rgb;  ///< info.width · info.height · 3 bytes
  /// The pixel at column `col`, row `row`.
  Color3u8 at(int col, int row) const {
    const std::size_t k = 3 * (static_cast<std::size_t>(row) * static_cast<std::size_t>(info.width) +
                               static_cast<std::size_t>(col));
    return Color3u8(rgb[k], rgb[k + 1], rgb[k + 2]);
  }
};

/// A cloud in its sensor frame and the pose of that sensor in the world.
struct PosedCloud {
  PointCloud cloud;                                    ///< points in the sensor frame
  Isometry3d T_world_sensor = Isometry3d::Identity();  ///< p_world = T_world_sensor · p_sensor
};

/// Progress of integrate(): called after each cloud with (done, total); return false to stop.
using IntegrateProgress = std::function<bool(std::size_t done, std::size_t total)>;

/// The occupancy map. Movable, not copyable.
class OccupancyMap {
 public:
  /// An empty map. Throws ConfigError when `params` are out of range (MappingParams::validate).
  explicit OccupancyMap(const MappingParams& params = {}, MapKind kind = MapKind::Occupancy);
  ~OccupancyMap();
  OccupancyMap(OccupancyMap&&) noexcept;
  OccupancyMap& operator=(OccupancyMap&&) noexcept;
  OccupancyMap(const OccupancyMap&) = delete;
  OccupancyMap& operator=(const OccupancyMap&) = delete;

  /// Reads a map written by writeBinary (`.bt`, gives an Occupancy map holding maximum-likelihood
  /// values) or writeFull (`.ot`, OcTree or ColorOcTree with their log-odds). The files store
  /// the resolution, which replaces `params.resolution`; every other parameter (probabilities,
  /// ranges) is taken from `params`. Throws IoError when the file cannot be read and FormatError
  /// naming it when OctoMap rejects it.
  static OccupancyMap read(const std::string& path, const MappingParams& params = {});

  const MappingParams& params() const noexcept;
  MapKind kind() const noexcept;

  /// Inserts a cloud given in the sensor frame, seen from T_world_sensor: the sensor origin is
  /// T_world_sensor's translation. Non-finite points and points nearer than min_range are dropped,
  /// the rest is voxel-filtered (prefilter_voxel), transformed to the world and ray-cast up to
  /// max_range. On a Color map the cloud's colours (when present) are averaged into the end cells.
  InsertResult insert(const PointCloud& cloud_sensor, const Isometry3d& T_world_sensor);

  /// Inserts clouds in order (e.g. the keyframes again after the poses were optimised: clear(),
  /// then integrate()). Calls `progress` after each; stops early when it returns false. Returns
  /// the number of clouds inserted.
  std::size_t integrate(const std::vector<PosedCloud>& clouds,
                        const IntegrateProgress& progress = {});
  /// The same with clouds and poses in two parallel arrays (no copy of the clouds); throws
  /// ContractError when their sizes differ.
  std::size_t integrate(const std::vector<PointCloud>& clouds_sensor,
                        const std::vector<Isometry3d>& T_world_sensor,
                        const IntegrateProgress& progress = {});

  /// Removes every node (parameters and kind stay).
  void clear();

  /// Merges children with identical values into their parent (lossless for occupancy).
  void prune();

  /// State of the leaf holding world point `p_world`.
  CellState state(const Eigen::Vector3d& p_world) const;
  /// Occupancy probability of the leaf holding `p_world`; a negative value when unknown.
  double occupancy(const Eigen::Vector3d& p_world) const;
  /// Averaged colour of the leaf holding `p_world`; false when the map is not a Color map or the
  /// cell is unknown or has no colour.
  bool color(const Eigen::Vector3d& p_world, Color3u8& rgb) const;
  /// Centre of the leaf voxel holding `p_world` at the finest resolution.
  Eigen::Vector3d voxelCenter(const Eigen::Vector3d& p_world) const;

  /// Centres and edges of the occupied leaves (for display or checks).
  void occupiedVoxels(std::vector<Eigen::Vector3d>& centers, std::vector<double>& sizes) const;

  /// Counts and volumes of the map; walks every leaf (about 30 ms per million leaves).
  MapStats stats() const;

  /// Writes OctoMap's binary `.bt` (maximum likelihood: each leaf free or occupied) atomically,
  /// after pruning. The file's tree id is always "OcTree", also for a Color map, so
  /// `octomap::OcTree::readBinary` reads it. Throws IoError on failure.
  void writeBinary(const std::string& path);
  /// Writes OctoMap's full `.ot` (log-odds of every node, plus colours for a Color map) atomically,
  /// after pruning. Throws IoError on failure.
  void writeFull(const std::string& path);
  /// writeBinary for `*.bt`, writeFull for `*.ot`; ConfigError for another extension.
  void write(const std::string& path);

  /// Renders the top view: each pixel column shows the height of the highest occupied voxel
  /// (blue low → green → yellow → red high, see TopViewInfo::z_low), or its colour in a Color
  /// map, light grey where the column is known free only, white where unknown. Throws
  /// ContractError for an empty map. (obm-map and obm-octomap write it as a PNG.)
  TopView renderTopView(const TopViewOptions& options = {}) const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
  explicit OccupancyMap(std::unique_ptr<Impl> impl);
};

/// A short human-readable multi-line summary of `stats` (nodes, leaves, volumes, memory, bbox).
std::string formatStats(const MapStats& stats);

}  // namespace obm::mapping
