#pragma once
/// \file obmnet_matcher.hpp
/// Scan matchers around the OBMNet network (libs/obmnet's ObmNetRegistrar, kept behind a pimpl so
/// LibTorch never reaches this header): OBMNet alone, and OBMNet followed by point-to-plane ICP.
/// The information matrix weights the residuals of the network's sampled source points by
/// α·w_i inside the sampled overlap and by w_i outside (docs/registration.md, "Confidence").
/// In a build without LibTorch the constructors throw ConfigError.
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "obm/obmnet/registrar.hpp"
#include "obm/registration/correlative_search.hpp"
#include "obm/registration/free_space.hpp"
#include "obm/registration/scan_matcher.hpp"

namespace obm {
class ConfigNode;
}  // namespace obm

namespace obm::registration {

/// Settings of the OBMNet matchers: the network pass (the registrar's own options, `network`) and
/// what the matchers do around it (the starts, the ICP refinements and the choice among them).
/// One YAML map holds both (config/registration/obmnet_icp.yaml lists every key).
struct ObmNetMatcherParams {
  /// The network pass: model_path (required), num_points (0 = as trained), threads, seed,
  /// denoise_neighbors, soft_sampling, yaw_hypotheses, iterations, spatial_sigma and RANSAC on
  /// its matches (ransac_iterations, ransac_candidates, ransac_inlier_spacing,
  /// ransac_max_turn_deg, select_by_consensus), start_heading_margin and min_consensus — each
  /// documented in obm/obmnet/registrar.hpp. `min_consensus` applies to ObmNetMatcher (the
  /// network alone) only: the refining matchers let ICP and the confidence judge every
  /// hypothesis. keep_start_if_fitter and the teacher are not matcher settings (not read).
  obmnet::ObmNetRegistrar::Options network;
  /// Transform the source by the initial guess before the network and compose the network's
  /// (small) correction with it: T = ΔT · T_init. The natural choice for odometry, where the
  /// constant-velocity guess is good; false = the network sees the raw clouds and T_init is
  /// ignored by ObmNetMatcher.
  bool pre_align = true;
  /// ObmNetIcpMatcher: start ICP from T_init instead of the network's pose when T_init pairs more
  /// source points within the first ICP gate (guards odometry against a network failure).
  bool keep_init_if_better = true;
  /// ObmNetIcpMatcher, overlap stage (0 = off): before the ICP on the whole source, an ICP on
  /// this fraction of the network's sampled source points — those with the largest SVD weights
  /// ω_i = w_i·(1 + α·m_i), i.e. the points the network places in the overlap — from a gate of
  /// `overlap_stage_gate_factor` × the ICP's fine gate, without the polish. On low-overlap pairs
  /// the parts outside the overlap otherwise pair with the wrong surface inside the gate and hold
  /// the refinement back. The full ICP then runs from both the stage's pose and the network's and
  /// keeps the one pairing more points (partial_noise: 54.0 → 62.0 % recall, docs/registration.md).
  double overlap_stage_keep = 0.0;
  double overlap_stage_gate_factor = 2.0;  ///< start gate of the overlap stage / fine gate
  /// ObmNetIcpMatcher: how many of the network's yaw hypotheses ICP refines, best first by the
  /// network's own ranking (its fitness, or its consensus with select_by_consensus; 1 = only the
  /// first; 0 = all). The refinement with the most inliers
  /// (source points within ConfidenceParams::inlier_threshold) is returned, with the α and
  /// weights of its hypothesis.
  /// For pairs without a heading prior (loop candidates, relocalisation), where the network's
  /// keypoint fitness sometimes prefers a wrong heading; each extra hypothesis costs one ICP.
  int refine_hypotheses = 1;
  /// ObmNetIcpMatcher: ICP also from the initial guess turned about the source's z axis by
  /// 360°·h/N, h = 0 … N−1 (0 = off), competing with the network's refined hypotheses on the same
  /// count of inliers. The classical headings and the network's poses fail on different
  /// pairs (loop candidates seen from the other direction, docs/benchmarks.md): together they
  /// register more than either. Each heading costs one ICP.
  int init_headings = 0;
  /// Start gate of the ICP from each blind heading [m] (annealed down to the fine gate as usual);
  /// 0 = the ICP's own initial gate. Without the network's pose a heading start can be metres
  /// off, so it needs the wide basin of plain ICP, while the refinement of the network's poses
  /// keeps its narrow one.
  double init_headings_gate = 0.0;
  /// A blind heading replaces the network's refined pose only when it has this many times the
  /// inliers (≥ 1). The network's pose carries the network's evidence, a heading's only its
  /// count; between two sweeps of a street a pose turned by 180° fits almost as well as the true
  /// one. 1.08 separates the wins from the losses of the blind headings on the benchmark's loop
  /// and (i, i+20) pairs (docs/benchmarks.md, "Every hypothesis refined").
  double init_headings_margin = 1.08;
  /// ObmNetIcpMatcher, more starts (0 = off): the network and its ICP also run from the guess
  /// turned by +start_turn_deg and by −start_turn_deg about each axis of the source frame named
  /// in start_turn_axes (a turn about the source's origin, the sensor), and the refinement with
  /// the highest bias-weighted confidence (MatchResult::network_confidence) is returned. For
  /// 6-DoF pairs without a good guess (RGB-D frames far apart, relocalisation): a network with a
  /// spatial prior corrects the start it is given but reaches only so far from it, and its
  /// confidence tells the starts that arrived from those that did not (docs/registration.md,
  /// "More starts"). Each start costs one network pass and its ICP.
  double start_turn_deg = 0.0;
  /// The axes of the start turns, any of x, y and z, each at most once. For a camera frame (x
  /// right, y down, z forward) "xy" turns the view up/down and left/right.
  std::string start_turn_axes = "xy";
  /// ObmNetIcpMatcher, starts from a correlative search (0 = off): the search over the heading
  /// about `search.axis` and the translation (correlativeSearch, relative to the guess) hands its
  /// best `search_candidates` poses on; ICP runs from each of them, and the results compete with
  /// the other starts on the bias-weighted confidence (with the SVD weights of the network's
  /// pass from the guess). For pairs turned about a vertical by more than the network and ICP
  /// reach from the guess (RGB-D frames far apart: docs/registration.md, "Correlative search").
  /// Each pose costs one ICP.
  int search_candidates = 0;
  CorrelativeSearchParams search;  ///< YAML `search:`; its `candidates` is search_candidates
  /// [m] ObmNetIcpMatcher with start turns or the search: when > 0, the starts' refinements
  /// compete on the bias-weighted confidence counted on the target's surface, a network point
  /// landing when it is also within this distance of its nearest target point's tangent plane
  /// (the whole distance where that normal is not trusted), instead of within the confidence's
  /// inlier threshold alone (0). Every refinement converges onto some surface; at the noise's
  /// scale only the right one lies on it (docs/registration.md, "Correlative search"). The
  /// returned confidence is always the usual one.
  double choice_plane_distance = 0.0;
  /// ObmNetIcpMatcher with start turns or the search (0 = off): the starts' refinements compete
  /// on the bias-weighted confidence times s^β, β this power and s the share of the whole
  /// source's points that are inliers at the pose (coloured inliers where the pair has colours).
  /// The confidence counts the network's points, weighted by where the module places the
  /// overlap; s counts every point alike. A pose turned onto another wall can land the
  /// network's heaviest points and still leave most of the frame unpaired (depth frame pairs:
  /// docs/benchmarks.md, "Choosing among the starts of frame pairs"). The returned confidence
  /// is the usual one.
  double choice_inlier_power = 0.0;
  /// ObmNetIcpMatcher on sensor sweeps, free space (free_space.hpp; 0 = off): every competition
  /// among refined poses (the yaw hypotheses, the blind headings, the start turns, the search's
  /// poses) multiplies a pose's score by max(0, 1 − λ·r), with λ this weight and r the share of
  /// both sweeps' points the pose puts into the other sweep's free space. Both sweeps must be in
  /// their sensor's frame (the sensor at the origin), as a LiDAR sweep is. Along a street of
  /// repeated facades a slide by a block pairs as many points as the right pose, but moves the
  /// parked cars and poles into road the other sweep looked through (docs/registration.md,
  /// "Free space"). The returned confidence is the usual one.
  double choice_free_space_weight = 0.0;
  /// Both OBMNet matchers (0 = off): the network's yaw hypotheses ranked by the registrar's score
  /// (consensus share or fitness) times max(0, 1 − λ·r), λ this weight, before the first is
  /// returned or refined. It helps where the network's right hypothesis is also right in
  /// translation, and misleads where that one is slid along the street (then a turned pose that
  /// puts the sweep out of the other's view has fewer conflicts): docs/benchmarks.md, "Free space".
  double hypothesis_free_space_weight = 0.0;
  FreeSpaceParams free_space;  ///< YAML `free_space:`: the range images of the choice

  /// Reads the keys of `node` (model_path required; unknown keys rejected). A relative
  /// model_path is resolved against the folder of the YAML file.
  static ObmNetMatcherParams load(const ConfigNode& node);
};

/// Why `axes` is not a valid ObmNetMatcherParams::start_turn_axes (empty = valid): only x, y and
/// z, each at most once, at least one.
std::string startTurnAxesError(const std::string& axes);

/// The extra starts of ObmNetMatcherParams::start_turn_deg: for each axis of `axes` (valid, see
/// startTurnAxesError) the turn by +deg, then by −deg, about that axis of the source frame (about
/// its origin). Empty when deg is 0.
std::vector<Isometry3d> startTurns(double deg, const std::string& axes);

/// The score on which refined starts compete (ObmNetMatcherParams::choice_inlier_power):
/// `confidence` · `inlier_share`^`inlier_power`, the confidence alone when the power is 0. For a
/// returned MatchResult: startChoiceScore(r.network_confidence, r.inlier_ratio, β).
double startChoiceScore(double confidence, double inlier_share, double inlier_power);

/// Whether this build has the OBMNet matchers (LibTorch); without it they throw ConfigError.
bool obmNetAvailable() noexcept;

/// OBMNet alone: the pose is the network's; the confidence is evaluated at it.
class ObmNetMatcher : public ScanMatcher {
 public:
  /// Loads the model (IoError / FormatError naming the file). `icp` supplies the residual model
  /// used to evaluate the confidence (fine gate, kernel, normals, voxels).
  ObmNetMatcher(const ObmNetMatcherParams& params, const IcpParams& icp = IcpParams(),
                const ConfidenceParams& confidence = ConfidenceParams());
  ~ObmNetMatcher() override;
  std::string name() const override { return "obmnet"; }
  bool global() const override { return true; }
  /// The loaded model's summary.
  std::string describe() const;

 protected:
  MatchResult impl_match(const PointCloud& source, const PreparedTarget& target,
                         const Isometry3d& T_target_source_init) const override;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

/// OBMNet for the coarse pose, then point-to-plane ICP refinement.
class ObmNetIcpMatcher : public ScanMatcher {
 public:
  ObmNetIcpMatcher(const ObmNetMatcherParams& params, const IcpParams& icp = IcpParams(),
                   const ConfidenceParams& confidence = ConfidenceParams());
  ~ObmNetIcpMatcher() override;
  std::string name() const override { return "obmnet+icp"; }
  bool global() const override { return true; }
  std::string describe() const;

 protected:
  MatchResult impl_match(const PointCloud& source, const PreparedTarget& target,
                         const Isometry3d& T_target_source_init) const override;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

/// The Overlap Bias Matching Module as a plug-in for ICP (`obmm+icp`): the network runs only to
/// predict which source points lie in the overlap and how much to trust them, ω_i = w_i·(1 +
/// α·m_i) (docs/model.md, step 8); its pose is not used. ICP then starts from the caller's guess
/// (as plain ICP does) with every source point's residual weighted by the ω of its nearest
/// network point, so that the parts the network places outside the overlap pull less. Compare
/// with `icp` on the same pairs to see what the module alone adds.
class ObmmIcpMatcher : public ScanMatcher {
 public:
  ObmmIcpMatcher(const ObmNetMatcherParams& params, const IcpParams& icp = IcpParams(),
                 const ConfidenceParams& confidence = ConfidenceParams());
  ~ObmmIcpMatcher() override;
  std::string name() const override { return "obmm+icp"; }
  bool global() const override { return false; }

 protected:
  MatchResult impl_match(const PointCloud& source, const PreparedTarget& target,
                         const Isometry3d& T_target_source_init) const override;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

/// The module's overlap prediction for a pair, for plug-ins outside this library (e.g. feature
/// matching restricted to the overlap): the network's SVD weights ω_i of its sampled source
/// points, and the same for the target (the pair swapped). Throws ConfigError without LibTorch.
struct OverlapPrediction {
  std::vector<Vector3f> source_points, target_points;  ///< sampled points, input frames
  std::vector<double> source_weights, target_weights;  ///< ω_i ≥ 0, one per point
  double alpha = 1.0;
};
class OverlapPredictor {
 public:
  explicit OverlapPredictor(const ObmNetMatcherParams& params);
  ~OverlapPredictor();
  OverlapPrediction predict(const PointCloud& source, const PointCloud& target) const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace obm::registration
