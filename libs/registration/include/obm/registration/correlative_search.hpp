#pragma once
/// \file correlative_search.hpp
/// A global start for pairs whose relative motion is mostly a turn about one known axis (the
/// vertical of a level camera or a LiDAR) plus a translation of up to about a metre: depth frames
/// many frames apart, relocalisation near a known place. An exhaustive correlative search over
/// the heading about that axis and the 3-D translation (docs/registration.md, "Correlative
/// search"): the source's points, turned by each heading, are shifted over a grid of translations
/// and scored by how many land in the target's occupied cells. No features and no
/// correspondences, so it does not depend on how the two clouds were sampled; the price is
/// that the search covers only the range it is given and ranks by occupancy alone, so its poses
/// are starts for a refinement that chooses among them, not answers.
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "obm/core/point_cloud.hpp"
#include "obm/core/se3.hpp"

namespace obm {
class ConfigNode;
}  // namespace obm

namespace obm::registration {

/// Settings of correlativeSearch (YAML keys of the same names).
struct CorrelativeSearchParams {
  /// The turn axis in the source frame: "x", "y" or "z" (a camera frame's vertical is y, a
  /// LiDAR's z), or "any": every rotation within `heading_range_deg` of the guess, on a grid of
  /// rotation vectors `heading_step_deg` apart (objects seen from anywhere; about 4/3·π·(range /
  /// step)³ rotations, so a coarser step than about one axis).
  std::string axis = "y";
  /// Take the turn axis from the target's floor (or ceiling, or road) instead: the mean normal
  /// of the target's planar patches within `max_tilt_deg` of `axis` (mapped to the source frame
  /// by the guess). A camera looking down turns about the room's vertical, not about its own y;
  /// without enough such patches `axis` itself is used. Not with axis "any".
  bool axis_from_floor = true;
  double max_tilt_deg = 30.0;  ///< [deg] how far the floor's normal may lie from `axis`
  /// [deg] headings in [−range, +range] about `axis` (axis "any": turns of up to range)
  double heading_range_deg = 60.0;
  double heading_step_deg = 3.0;    ///< spacing of the headings
  double translation_range = 1.0;   ///< [m] translations in [−range, +range] along each axis
  /// [m] the range along `axis` itself (−1 = translation_range): a level sensor moves little
  /// along its vertical, and each cell less there divides the search's cost. Not with axis "any".
  double axial_range = -1.0;
  /// Turn the source about its centroid and centre the translations where the two centroids
  /// meet, instead of turning about the source's origin and centring them on the guess: for
  /// clouds whose origin is not their sensor's (objects, fragments), where a turn about the
  /// origin would swing the cloud away and the translation range would have to cover that.
  bool align_centroids = false;
  /// [m] the coarse grid's cell, also the step of the translations; the best translation of each
  /// heading is then refined on a grid of half this cell.
  double cell = 0.1;
  int sample_points = 1000;  ///< source points scored (a fixed random subset; 0 = all)
  int candidates = 8;        ///< poses returned, best first
  /// Translations kept per heading (pairwise min_separation_m apart) before the poses of all
  /// headings are ranked: the right place can score a little below a slide at the same heading.
  int shifts_per_heading = 3;
  /// Two returned poses differ by at least this heading or this translation [deg, m].
  double min_separation_deg = 10.0;
  double min_separation_m = 0.3;
  /// Grey-level agreement (0 = off; grey levels in [0, 1]): when both clouds carry colours, a
  /// source point in an occupied cell whose grey level differs from the cell's mean by more
  /// than this counts as a point next to one.
  double color_tolerance = 0.05;
  std::uint64_t seed = 0;  ///< seeds the source subset

  /// Throws ConfigError naming the field when a value is out of range.
  void validate() const;
  /// Reads the keys of `node` (unknown keys rejected with their line).
  static CorrelativeSearchParams load(const ConfigNode& node);
};

/// One pose of the search and its score.
struct SearchHit {
  Isometry3d T_target_source = Isometry3d::Identity();
  double heading_deg = 0.0;  ///< the turn about the axis, relative to T_init
  /// The turn axis in the source frame (CorrelativeSearchParams::axis, or the floor's normal;
  /// with axis "any" the axis of this pose's turn, heading_deg its angle).
  Eigen::Vector3d axis = Eigen::Vector3d::UnitY();
  /// Share of the scored source points in an occupied target cell (1 per point in an occupied
  /// fine cell, ½ in a cell next to one or, with colour_tolerance, in an occupied cell of another
  /// grey level), in [0, 1].
  double score = 0.0;
};

/// The mean normal of the planar patches of `points` (cells of `cell` with at least six points,
/// thin in one direction) that lie within `max_tilt_deg` of `nominal`, signed towards it, found
/// by a mean shift from `nominal`; nullopt when fewer than 20 patches or under 5 % of the planar
/// ones are there, at `cell` and at 2, 4 and 8 times it (for sparse clouds). The floor's (or
/// road's) normal of a cloud whose sensor's vertical is about `nominal`.
std::optional<Eigen::Vector3d> floorNormal(const std::vector<Vector3f>& points, double cell,
                                           const Eigen::Vector3d& nominal, double max_tilt_deg);

/// Searches T = Δ(θ, t) · T_init over the headings θ about `params.axis` of the source frame
/// (turns about the source origin, composed before T_init: T = T_init · [R_axis(θ) | 0], then
/// shifted by t in the target frame; with `align_centroids` turns about the source's centroid,
/// shifted by t from where the centroids meet) and the translations t, and returns up to
/// `params.candidates` poses, best score first, pairwise separated by the minimum turn (the angle
/// between their rotations) or translation. Empty when either cloud is empty. Deterministic for
/// a seed.
std::vector<SearchHit> correlativeSearch(const PointCloud& source, const PointCloud& target,
                                         const CorrelativeSearchParams& params,
                                         const Isometry3d& T_target_source_init =
                                             Isometry3d::Identity());

}  // namespace obm::registration
