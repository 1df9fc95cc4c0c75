#pragma once
/// \file params.hpp
/// Parameters of the SLAM front-end (docs/obm-map.md, "Configuration"): plain structs with
/// in-class defaults (tuned for a 10 Hz 64-beam LiDAR in metres), each loaded from YAML in exactly
/// one place, its `load`. Unknown keys and out-of-range values throw ConfigError naming the file
/// and the key. Angles are degrees in YAML (`*_deg`) and radians here.
#include <cstddef>
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "obm/backend/optimizer.hpp"
#include "obm/backend/pose_graph.hpp"
#include "obm/core/se3.hpp"
#include "obm/registration/factory.hpp"
#include "obm/registration/params.hpp"

namespace obm {
class ConfigNode;
}

namespace obm::frontend {

/// Preprocessing of every sweep before it is registered (YAML `preprocess:`).
struct PreprocessParams {
  double min_range = 2.0;    ///< [m] nearer points are dropped (returns from the vehicle)
  double max_range = 100.0;  ///< [m] farther points are dropped; <= 0 = no upper bound
  /// [m] voxel grid of the scan that is registered (one centroid per voxel); 0 = off.
  double voxel = 0.5;
  /// Random N-point sample after the voxel grid (seeded, reproducible); 0 = keep every point.
  std::size_t max_points = 0;
  std::uint64_t seed = 0;  ///< seed of the N-point sampling

  static PreprocessParams load(const ConfigNode& node);
  void validate() const;
};

/// When a frame becomes a keyframe (YAML `keyframes:`): a pose-graph node, a local-map member.
struct KeyframeParams {
  double distance = 4.0;               ///< [m] travelled since the last keyframe
  double rotation = 10.0 * kDegToRad;  ///< [rad] rotated since the last keyframe (YAML `_deg`)
  std::size_t max_frames = 0;          ///< at least every N tracked frames; 0 = no limit
  /// Overlap keyframes: a tracked frame whose inlier ratio fell below this fraction of the recent
  /// frames' median is a keyframe (at least `overlap_min_frames` after the last one), so geometry
  /// that comes into view (a doorway, a turn towards an unmapped room) enters the local map
  /// before the tracker's relative inlier test (tracking.relative_inlier_ratio) rejects frames
  /// for it. 0 = off (distance, rotation and max_frames only).
  double overlap_drop = 0.0;
  /// Frames between two overlap keyframes: the asynchronous local map takes the new keyframe
  /// from the third frame after it (LocalMapParams::async), and the ratio keeps falling until then.
  std::size_t overlap_min_frames = 3;
  /// [m] Memory on revisits: a keyframe that leaves the local map within this distance of an
  /// older keyframe of an earlier pass (at least loop_closure.min_travel back along the path)
  /// that still holds its cloud drops its own cloud and place descriptor. The place is stored
  /// already, so the resident set stops growing once the drive only revisits; the keyframe stays
  /// a pose-graph node but is no loop candidate and adds no points to keyframes.simplemap or
  /// scene.3Dscene (the OctoMap is built from the sweeps and is not affected). 0 = keep every
  /// cloud.
  double revisit_radius = 0.0;

  static KeyframeParams load(const ConfigNode& node);
  void validate() const;
};

/// The local map every frame is registered against (YAML `local_map:`): the clouds of the most
/// recent keyframes at their current pose estimates, merged on a voxel grid in the world frame.
struct LocalMapParams {
  std::size_t keyframes = 15;  ///< recent keyframes merged into the local map
  /// [m] voxel grid of each keyframe's stored cloud and of the merged map (one centroid per voxel).
  double voxel = 0.3;
  double radius = 100.0;  ///< [m] map points farther than this from the newest keyframe are dropped
  /// Rebuild the map in a worker thread while tracking goes on; the new map is used from the
  /// third frame after the keyframe (a fixed frame: results do not depend on timing). After a
  /// loop closure or a restart the map is rebuilt at once.
  bool async = true;
  /// Rebuild the map at every n-th keyframe only (>= 1): building the KD-tree and normals is the
  /// front-end's largest cost, and a map reaching 100 m stays good for a few keyframes.
  std::size_t rebuild_every = 1;
  /// Estimate each keyframe's normals (and colour gradients) once, on its own cloud, and merge
  /// them into the local map (per voxel the mean of the trusted ones) instead of estimating them
  /// on every merged map: the build then only merges and builds the KD-tree. The k-NN search of
  /// the estimate is most of a build, and indoors a keyframe comes every few frames. Off: the
  /// normals of a merged map see several views at once, which sparse LiDAR rings need.
  bool keyframe_normals = false;

  static LocalMapParams load(const ConfigNode& node);
  void validate() const;
};

/// Frame-to-local-map tracking and what happens when it fails (YAML `tracking:`).
struct TrackingParams {
  registration::IcpParams icp;  ///< the scan-to-local-map point-to-plane ICP (YAML `icp:`)
  registration::ConfidenceParams confidence;  ///< its confidence model (YAML `confidence:`)
  /// A match is accepted when its status is ok / not_converged / degenerate, its quality is at
  /// least this, and it corrects the constant-velocity guess by at most the bounds below. [0, 1]
  double min_quality = 0.3;
  double max_correction = 1.0;                     ///< [m] |translation of guess⁻¹·estimate|
  double max_correction_rotation = 5 * kDegToRad;  ///< [rad] rotation of guess⁻¹·estimate
  /// A match is also rejected when its inlier ratio falls below this fraction of the median
  /// inlier ratio of the last 10 tracked frames: a wrong local minimum still pairs the ground and
  /// the facades but loses the rest, which an absolute threshold misses in a street. [0, 1]
  double relative_inlier_ratio = 0.7;
  /// A match that fails only relative_inlier_ratio is still taken when it lands within these
  /// bounds of the constant-velocity guess and keeps at least guess_agreement_relative_inlier_ratio
  /// of the recent median inlier ratio: prediction and registration agree, and the fall in the
  /// inlier ratio is the view moving into space the local map has not seen yet (a fast turn or a
  /// doorway indoors), which the overlap keyframes (keyframes.overlap_drop) then add to the map.
  /// Without it such frames are bridged, the map stops growing and the track is lost a few frames
  /// later. Needs a motion prior (from the third frame). 0 = off.
  double guess_agreement_translation = 0.0;                ///< [m]
  double guess_agreement_rotation = 1.0 * kDegToRad;       ///< [rad] (YAML `_deg`)
  double guess_agreement_relative_inlier_ratio = 0.3;      ///< [0, 1]
  /// [m] recovery (after a rejected match): ICP from the same guess with the correspondence gate
  /// annealed from this value down to the tracking gate. 0 = no recovery attempt.
  double recovery_gate = 4.0;
  double recovery_max_correction = 6.0;  ///< [m] largest correction a recovery may make
  /// Minimum quality of a recovered match (stricter than min_quality: the guess was off). [0, 1]
  double recovery_min_quality = 0.4;
  /// ... and fraction of the recent median inlier ratio it must reach (a correct recovery
  /// registers against the same local map as the frames before, so it fits as well). [0, 1]
  double recovery_relative_inlier_ratio = 0.8;
  /// Recovery starts from the guess and from the guess turned by ±k·step about the axis of the
  /// last motion (the vertical for a car), k = 1 … hypotheses; the best accepted match wins.
  double recovery_rotation_step = 10.0 * kDegToRad;  ///< [rad] (YAML `_deg`)
  int recovery_rotation_hypotheses = 2;              ///< k of each sign (0 = the guess only)
  /// A second opinion for a recovery that fails only the relative inlier ratio (after a gap in
  /// the sweeps the car has moved into parts the local map has not seen, so a right match pairs
  /// fewer points than the frames before): the scan matcher registers the frame against the last
  /// keyframe alone, and when its pose (quality ≥ recovery_min_quality) agrees with the
  /// local-map match within this translation and rotation, the local-map match is taken.
  /// 0 = no second opinion.
  double recovery_agreement_translation = 0.0;           ///< [m]
  double recovery_agreement_rotation = 1.0 * kDegToRad;  ///< [rad] (YAML `_deg`)
  /// A sudden jump (sweeps lost without a gap in the time stamps, so the guess is metres off):
  /// the scan matcher's registration against the last keyframe may land on the jump, but one
  /// registration metres from the guess looks like a wrong local minimum and its inlier ratio
  /// falls with the overlap. One that fails only recovery_relative_inlier_ratio and
  /// recovery_max_correction is kept as a candidate; it is taken when the next sweep's
  /// registration lands on it moved by the constant-velocity step (within
  /// recovery_agreement_translation / _rotation), and the candidate sweep, bridged meanwhile, is
  /// moved to its registered pose. Needs recovery_agreement_translation > 0.
  bool recovery_confirm_jumps = false;
  /// A recovery beyond max_correction is taken as a jump (lost sweeps): the history moves with
  /// it and the velocity before it is kept. When the frame before was such a jump too, the guess
  /// is off every frame: the velocity itself is wrong (extrapolated over a gap, a turn rate kept
  /// after the turn ended), and it is re-estimated from the recovered poses instead. Without it a
  /// wrong velocity after a local-map restart is corrected anew at every frame, no frame is
  /// tracked, and the local map never grows.
  bool recovery_repeated_jump_is_velocity = false;
  /// A recovery taken on a confirmation (the second opinion, a confirmed jump) still needs this
  /// share of the recent inlier ratio: two registrations from the same guess can agree on the
  /// same wrong pose (metres along a straight street). [0, 1]
  double recovery_confirmed_relative_inlier_ratio = 0.0;
  /// After a gap in the time stamps the constant-velocity guess extrapolates the turn rate over
  /// the gap, and the car may have turned less or more meanwhile: the recovery's rotation bound
  /// (4 × max_correction_rotation) and its rotation hypotheses grow by the turn extrapolated
  /// beyond one frame's motion. false = the bound and hypotheses of a frame without a gap.
  bool recovery_gap_rotation = false;
  /// A wide-gate registration that corrects the guess by more than the recovery's rotation bound,
  /// but pairs at least this share of the recent median inlier ratio (as many points as the
  /// tracked frames: a wrong local minimum degrees away does not), is taken. It catches sweeps
  /// lost in a turn without a gap in the time stamps, where the guess falls short of the turn.
  /// 0 = never (the bound holds). [0, 1]
  double recovery_large_turn_relative_inlier_ratio = 0.0;
  /// Gap paths (a recovery step after a gap in the time stamps, when the wide-gate recovery found
  /// nothing): the constant-velocity guess extrapolates the turn rate over the whole gap (a car in
  /// a turn 4 s long at 32 deg/s is guessed 130 deg round, 15 m along the arc), so the guess is no
  /// start. The hypotheses are the paths that turn at the last rate for part of the gap (every
  /// turn_step of heading up to the whole turn) then drive straight, at speeds from speed_min to
  /// speed_max × the last one; each starts the wide-gate ICP against the local map. The fittest
  /// acceptable registration (recovery_min_quality, relative_inlier_ratio below: the car has driven
  /// into space the local map has not seen, so a right registration pairs fewer points than the
  /// frames before the gap; no correction bound) is taken when min_support starts reach it (within
  /// the agreement tolerances) and no acceptable registration elsewhere reaches rival_ratio of its
  /// inlier ratio. The step runs when the guess extrapolates the last motion over at least this
  /// many frame intervals (a gap of min_steps − 1 frames); 0 = never.
  double recovery_gap_min_steps = 0.0;
  double recovery_gap_turn_step = 15.0 * kDegToRad;  ///< [rad] (YAML `_deg`)
  double recovery_gap_speed_min = 0.6;               ///< × the last speed, > 0
  double recovery_gap_speed_max = 2.0;               ///< × the last speed, >= min
  /// [m] the speeds between min and max (and, for jumps, the numbers of lost sweeps) are spread
  /// so that the ends of neighbouring paths are at most this far apart. > 0
  double recovery_gap_start_spacing = 2.0;
  /// [rad] after a straight stretch (less than turn_step to continue over the gap) the paths
  /// also take a corner half-way, by each of these angles either side (YAML `_deg`).
  std::vector<double> recovery_gap_corner_turns{30.0 * kDegToRad, 60.0 * kDegToRad,
                                                90.0 * kDegToRad};
  double recovery_gap_relative_inlier_ratio = 0.4;                                  ///< [0, 1]
  int recovery_gap_min_support = 2;                                                 ///< >= 1
  double recovery_gap_rival_ratio = 0.9;                                            ///< (0, 1]
  double recovery_gap_agreement_translation = 0.3;                                  ///< [m]
  double recovery_gap_agreement_rotation = 1.0 * kDegToRad;  ///< [rad] (YAML `_deg`)
  /// [m] The gap paths also register against the map made earlier around each path's end: the
  /// keyframes older than the local map within this radius of the keyframe nearest to the end
  /// (merged at the local map's voxel). After a long gap in a turn the car is often tens of
  /// metres into a street the local map barely sees, but which an earlier pass mapped; the
  /// registrations against both compete as above. 0 = the local map only.
  double recovery_gap_map_radius = 0.0;
  /// Jump paths: the same step when the time stamps hide the loss (sweeps lost, stamps regular):
  /// the guess is one step and the number of lost sweeps is unknown, so the paths are those of
  /// 1 + k lost steps at the last speed, k up to recovery_jump_max_steps (spaced by
  /// recovery_gap_start_spacing), judged as above. 0 = never. Neither step starts from a bridged
  /// frame (its pose is a guess).
  int recovery_jump_max_steps = 0;
  /// After this many bridged frames in a row the local map is restarted from the current frame
  /// (a keyframe joined to the previous one by a weak bridge edge). >= 1.
  std::size_t max_bridge_frames = 10;
  /// Multiplies the information Ω = H/σ² of the match before the floor below. > 0
  double information_scale = 1.0;
  /// Covariance floor of odometry edges: Ω_edge = (Ω⁻¹ + diag(σ_t² I, σ_r² I))⁻¹, computed as
  /// Ω (I + Σ_floor Ω)⁻¹ so a rank-deficient Ω (degenerate match) stays valid. It models what
  /// H/σ² leaves out (correlated residuals, voxelisation), which makes Ω of dense scans
  /// over-confident by orders of magnitude. >= 0
  double floor_sigma_translation = 0.01;           ///< [m]
  double floor_sigma_rotation = 0.02 * kDegToRad;  ///< [rad] (YAML `_deg`)
  /// Standard deviations of a bridge edge (constant-velocity motion instead of a match).
  double bridge_sigma_translation = 1.0;           ///< [m]
  double bridge_sigma_rotation = 5.0 * kDegToRad;  ///< [rad] (YAML `_deg`)
  /// Scale the constant-velocity guess by the time between frames (time stamps), so dropped
  /// frames are bridged correctly; false = one frame, one velocity step.
  bool use_timestamps = true;
  /// Start search for a frame without a motion prior (the second frame: the sensor may already
  /// be moving at speed, and the guess is the last pose). A street of repeated facades has a
  /// local minimum every few metres along it, each as well-conditioned as the true one: the
  /// wide-gate ICP from the last pose can lock onto the wrong one and the velocity it gives
  /// keeps every later frame there. The wide-gate ICP also starts from the last pose moved by
  /// ±k·start_search_step along start_search_axis (sensor frame; the driving direction),
  /// k = 1 … start_search_range / step, and the start that pairs the most source points within
  /// the inlier threshold wins. 0 = the last pose only.
  double start_search_range = 0.0;  ///< [m]
  double start_search_step = 1.0;   ///< [m]
  Eigen::Vector3d start_search_axis = Eigen::Vector3d::UnitX();  ///< unit, sensor frame
  /// One more start for the search: the scan matcher's registration of the frame against the
  /// last keyframe (the network, for the OBMNet matchers: a global registration needs no
  /// prior). Runs also when start_search_range is 0.
  bool start_search_matcher = false;

  /// [rad] The largest rotation a recovery (or a frame without a velocity) may correct the
  /// guess by: 4 × max_correction_rotation.
  double recoveryMaxRotation() const { return 4.0 * max_correction_rotation; }

  static TrackingParams load(const ConfigNode& node);
  void validate() const;
};

/// Scan-context-like place descriptor (YAML `loop_closure.descriptor:`): the maximum height of the
/// points in each (ring, sector) polar bin around the sensor (Kim & Kim, "Scan Context", IROS
/// 2018), compared under all sector shifts.
struct DescriptorParams {
  int rings = 20;              ///< radial bins
  int sectors = 60;            ///< azimuthal bins
  double max_range = 80.0;     ///< [m] radius covered by the rings
  double height_offset = 2.0;  ///< [m] added to z so that the ground is ~0 and heights positive

  static DescriptorParams load(const ConfigNode& node);
  void validate() const;
};

/// Relocalisation after a local-map restart (YAML `loop_closure.relocalisation:`). Once the
/// front-end has lost the drive (a run of bridged frames), the keyframes since the restart form a
/// piece whose place in the world is unknown: the estimate may be tens of metres and degrees off,
/// so the proximity search of loop closure cannot find revisits. Each new keyframe of the piece is
/// compared by its place descriptor with every keyframe of the map before it; the closest are
/// verified by the scan matcher from the descriptor's yaw alone, and when `confirmations`
/// keyframes of the piece in a row agree on one correction, the piece is moved by it and joined to
/// the map by loop edges.
struct RelocalisationParams {
  bool enabled = true;
  /// [0, 1] candidates must be at least this similar (cosine distance of the descriptors); a
  /// revisit seen from the same lane is typically < 0.15, a different street > 0.3.
  double max_descriptor_distance = 0.25;
  std::size_t max_candidates = 3;  ///< candidates verified per keyframe (most similar first)
  /// Verified match: quality and inlier ratio at least these [0, 1]. Stricter than a proximity
  /// loop's: no estimate backs the match up. A street seen from its other end, at the wrong block,
  /// pairs 0.6–0.75 of the points at 180°; a re-observation of the place pairs > 0.95.
  double min_quality = 0.85;
  double min_inlier_ratio = 0.85;
  /// Keyframes of the piece (within the last 2 × confirmations) whose verified matches, each
  /// onto a different keyframe of the map, must agree on the correction before the piece is moved
  /// (1 = the first match moves it). Repeated blocks of a city can match one keyframe well at the
  /// wrong place; two places rarely give the same wrong correction.
  std::size_t confirmations = 2;
  double agreement_translation = 1.0;             ///< [m] corrections agree within this ...
  double agreement_rotation = 2.0 * kDegToRad;    ///< [rad] (YAML `_deg`) ... and this

  static RelocalisationParams load(const ConfigNode& node);
  void validate() const;
};

/// Loop closure (YAML `loop_closure:`): candidates near the current keyframe in the current
/// estimate but far back along the trajectory, verified by the scan matcher.
struct LoopClosureParams {
  bool enabled = true;
  double min_travel = 60.0;     ///< [m] a candidate is at least this far back along the trajectory
  double search_radius = 12.0;  ///< [m] base radius of the proximity search
  /// [m/m] the radius grows with the distance travelled since the candidate (drift allowance)
  double search_radius_per_m = 0.01;
  double max_search_radius = 30.0;  ///< [m] upper bound of the radius
  /// [rad] (YAML `max_view_angle_deg`) Candidates whose viewing direction (the sensor's optical
  /// axis z) differs from the current keyframe's by more than this are not verified: two RGB-D
  /// views ~60° wide that look apart share little or nothing, and a revisit walked the other way
  /// sees the other walls. 0 = no bound (a 360° LiDAR sees the place from any heading).
  double max_view_angle = 0.0;
  std::size_t check_every = 2;      ///< search at every N-th keyframe (>= 1)
  std::size_t max_candidates = 2;   ///< candidates verified per search (nearest first)
  /// After an accepted loop, the next search waits this many keyframes (0 = as check_every).
  std::size_t cooldown = 5;
  int submap_keyframes = 3;    ///< the candidate ± this many keyframes form the target submap
  bool use_descriptor = true;  ///< reject candidates whose descriptor distance is too large
  double max_descriptor_distance = 0.35;  ///< [0, 1] cosine distance of the descriptors
  double min_quality = 0.5;               ///< verified match: quality at least this [0, 1]
  double min_inlier_ratio = 0.4;          ///< verified match: inlier ratio at least this [0, 1]
  /// [m] the verified pose may differ from the current estimate by at most this (more is an
  /// implausible correction for the drift since the candidate). 0 = the search radius.
  double max_correction = 0.0;
  /// [rad] (YAML `_deg`) the verified pose may turn the current estimate by at most this plus
  /// `correction_rotation_per_m` per metre travelled since the candidate (heading drift). A
  /// registration at a symmetric place (a street of identical facades seen from the other end, a
  /// square room) can pair as many points at 180° as at the truth; the odometry's heading since
  /// the candidate rules it out. 0 = no bound.
  double max_correction_rotation = 0.0;
  double correction_rotation_per_m = 0.0;  ///< [rad/m] (YAML `_deg`)
  double information_scale = 1.0;  ///< multiplies the loop edge's information before the floor
  /// Covariance floor of loop edges (as TrackingParams::floor_sigma_*).
  double floor_sigma_translation = 0.02;           ///< [m]
  double floor_sigma_rotation = 0.05 * kDegToRad;  ///< [rad] (YAML `_deg`)
  /// Robust loss of loop edges in the pose graph ("none", "huber:δ", "cauchy:c", "dcs:Φ",
  /// "dcs:auto"). Φ = 1000 (χ² units): a true loop after metres of systematic drift, which the
  /// odometry information does not model, keeps its weight; a wrong one (χ² ~10⁷) is switched off.
  backend::EdgeLoss loss{backend::LossKind::Dcs, 1000.0};
  DescriptorParams descriptor;
  RelocalisationParams relocalisation;

  static LoopClosureParams load(const ConfigNode& node);
  void validate() const;
};

/// Everything the front-end needs (the root of the YAML minus the app's own sections).
struct FrontendParams {
  PreprocessParams preprocess;
  KeyframeParams keyframes;
  LocalMapParams local_map;
  TrackingParams tracking;
  LoopClosureParams loop_closure;
  /// The scan matcher of loop-closure verification and recovery (YAML `matcher:`, the keys of
  /// obm::ScanMatcherConfig plus `fallback`).
  registration::ScanMatcherConfig matcher;
  /// Matcher used instead when `matcher.type` runs the network and its model file does not exist
  /// (none: a missing model is an error).
  std::optional<registration::MatcherKind> matcher_fallback;
  backend::Options optimizer;  ///< pose-graph optimiser (YAML `optimizer:`, see config/graph.yaml)

  /// Reads the sections `preprocess`, `keyframes`, `local_map`, `tracking`, `loop_closure`,
  /// `matcher`, `optimizer` of `node` (all optional) and ignores none: call checkKeys on the root
  /// for the sections the caller adds.
  static FrontendParams load(const ConfigNode& node);
  /// The section names load() reads.
  static std::vector<std::string> sections();
  void validate() const;
};

}  // namespace obm::frontend
