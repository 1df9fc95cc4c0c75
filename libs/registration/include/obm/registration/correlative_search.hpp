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
  /// LiDAR's z).
  std::string axis = "y";
  /// Take the turn axis from the target's floor (or ceiling, or road) instead: the mean normal
  /// of the target's planar patches within `max_tilt_deg` of `axis` (mapped to the source frame
  /// by the guess). A camera looking down turns about the room's vertical, not about its own y;
  /// without enough such patches `axis` itself is used.
  bool axis_from_floor = true;
  double max_tilt_deg = 30.0;  ///< [deg] how far the floor's normal may lie from `axis`
  double heading_range_deg = 60.0;  ///< headings in [−range, +range] about `axis`
  double heading_step_deg = 3.0;    ///< spacing of the headings
  double translation_range = 1.0;   ///< [m] translations in [−range, +range] along each axis
  /// [m] the range along `axis` itself (−1 = translation_range): a level sensor moves little
  /// along its vertical, and each cell less there divides the search's cost.
  double axial_range = -1.0;
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
  /// The turn axis in the source frame (CorrelativeSearchParams::axis, or the floor's normal).
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
/// shifted by t in the target frame) and the translations t, and returns up to
/// `params.candidates` poses, best score first, pairwise separated by the minimum heading or
/// translation. Empty when either cloud is empty. Deterministic for a seed.
std::vector<SearchHit> correlativeSearch(const PointCloud& source, const PointCloud& target,
                                         const CorrelativeSearchParams& params,
                                         const Isometry3d& T_target_source_init =
                                             Isometry3d::Identity());

}  // namespace obm::registration
