#pragma once
/// \file registrar.hpp
/// The inference API of OBMNet: one call, (source, target) → T_target_source with the bias
/// coefficient α, the inlier weights and the overlap estimate. Loads a model file written by
/// obm-train (saveModel); needs no training code. LibTorch stays out of this header.
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "obm/core/point_cloud.hpp"
#include "obm/core/se3.hpp"
#include "obm/obmnet/config.hpp"

namespace obm::obmnet {

/// One yaw hypothesis of a registration (ObmNetRegistrar::Options::yaw_hypotheses): the network's
/// pose from that start and what the network said with it.
struct YawHypothesis {
  Isometry3d T_target_source = Isometry3d::Identity();  ///< input frames, like the result's
  double yaw_deg = 0.0;  ///< the turn of the source before the network [deg]
  double fitness = 0.0;  ///< RegistrationResult::fitness of this pose
  /// Share of the sampled source points in RANSAC's consensus on this pass's matches (−1 without
  /// Options::ransac_iterations).
  double consensus = -1.0;
  /// What the hypotheses were ranked by: the consensus share (Options::select_by_consensus with
  /// RANSAC) or the fitness, times Options::start_heading_margin for the start's heading.
  double score = 0.0;
  double alpha = 1.0;    ///< α of this pass
  double overlap = 1.0;  ///< overlap estimate of this pass
  std::vector<float> inlier_weights, overlap_membership;  ///< as in RegistrationResult
};

/// Result of one OBMNet registration.
struct RegistrationResult {
  Isometry3d T_target_source = Isometry3d::Identity();  ///< p_target = T · p_source
  double alpha = 1.0;    ///< bias coefficient α > 0 of the common structure (paper, BP module)
  double overlap = 1.0;  ///< the network's overlap estimate in [0, 1]
  /// Inlier weight w_i ∈ (0, 1] of each sampled source point (RIENet's inlier evaluation).
  std::vector<float> inlier_weights;
  /// Membership m_i = 1 − (1 − π_i)^K of each sampled source point in the overlap region drawn by
  /// the sampler: where α applies (ω_i = w_i·(1 + α·m_i)).
  std::vector<float> overlap_membership;
  /// The source points the network saw (input indices), aligned with inlier_weights.
  std::vector<std::size_t> source_indices;
  /// The sampled source and target points (input frames, not normalised).
  PointCloud source_sampled, target_sampled;
  double runtime_ms = 0.0;  ///< wall time of the call (sampling + network)
  /// Fraction of the sampled source points whose nearest sampled target point lies within twice
  /// the target's median point spacing at the returned pose: the score that chose among the yaw
  /// hypotheses unless Options::select_by_consensus with RANSAC (computed for every call).
  double fitness = 0.0;
  /// Yaw of the hypothesis the returned pose started from [deg] (0 with a single hypothesis).
  double hypothesis_yaw_deg = 0.0;
  /// With Options::keep_start_if_fitter: the network's poses were all less fit than its start
  /// (the pose it was given: the identity of the clouds as passed, after the pair
  /// normalisation), which is returned instead; with Options::min_consensus: too few of its
  /// matches agreed on the chosen hypothesis.
  bool kept_start = false;
  /// Every yaw hypothesis, best first by the score that chose (fitness, or the consensus with
  /// Options::select_by_consensus; one entry with a single hypothesis), for callers that
  /// verify more than the fittest (ObmNetIcpMatcher's refine_hypotheses).
  std::vector<YawHypothesis> hypotheses;
};

/// Registers point clouds with a trained OBMNet model.
class ObmNetRegistrar {
 public:
  struct Options {
    std::string model_path;  ///< a model file written by obm-train
    int num_points = 0;  ///< points sampled per cloud; 0 = the number the model was trained with
    int threads = 2;     ///< intra-op threads
    std::uint64_t seed = 0;  ///< seeds the point sampling (the Gumbel noise is seeded by the model)
    /// Neighbour-mean denoising of both sampled clouds before the network (0 = off): each point
    /// becomes the mean of itself and its `denoise_neighbors` nearest neighbours (see
    /// obmnet::neighbourMean). For per-point sensor noise the model was not trained on; the
    /// returned sampled clouds stay the raw points.
    int denoise_neighbors = 0;
    /// Yaw hypotheses: the source is also turned by 360°/H, 2·360°/H, … about z before the
    /// network, all H in one batch, and the pose with the best `fitness` is returned. For
    /// gravity-aligned scans seen from any heading (loop closures from the other direction),
    /// where one network pass covers about ±45°. 0 = the model's default (4 for a planar model,
    /// else 1); 1 = off.
    int yaw_hypotheses = 0;
    /// Overlap sampling at inference: −1 = as the model file says
    /// (ObmNetConfig::soft_inference_sampling), 0 = one-hot draws, 1 = the relaxed draws of
    /// training.
    int soft_sampling = -1;
    /// Verify the network against its start: the start is scored by the same `fitness` as the
    /// yaw hypotheses and returned when it is fitter than every one of them. The network then
    /// never moves a pair further from a good guess than its own score allows (consecutive
    /// sweeps, where not moving is often closer than the network's estimate).
    bool keep_start_if_fitter = false;
    /// Registration iterations of one pass (0 = the model's n_iters). The iterations share their
    /// weights; more of them than training ran let the network close larger start offsets in
    /// steps (sweeps far apart), each step from the source as the previous ones moved it.
    int iterations = 0;
    /// σ of the matching map's spatial prior (ObmNetConfig::match_spatial_sigma) [normalised
    /// units]: −1 = as the model file says, 0 = off, > 0 = this σ.
    double spatial_sigma = -1.0;
    /// A robust estimator on the network's correspondences (0 = off): RANSAC with this many
    /// minimal samples over the pairs (source point, its most probable target point in the last
    /// iteration's matching map), 4-DoF for planar models. Per hypothesis, the RANSAC pose replaces
    /// the weighted SVD's (see select_by_consensus for when). The weighted SVD averages every pair,
    /// so a minority of wrong matches far away pulls it off by metres on sweeps far apart; a
    /// consensus set ignores them.
    int ransac_iterations = 0;
    /// Target candidates per source point given to RANSAC, most probable first (1 … 4); a source
    /// point counts once in the consensus however many of its candidates agree.
    int ransac_candidates = 4;
    /// RANSAC's inlier distance in target point spacings (the median distance of a target point
    /// to its nearest neighbour): true pairs of two independent samplings lie about one spacing
    /// apart.
    double ransac_inlier_spacing = 1.0;
    /// Planar models: RANSAC keeps to poses turned at most this far from their hypothesis's
    /// heading [deg] — the ±45° a network pass was trained to cover.
    double ransac_max_turn_deg = 45.0;
    /// With ransac_iterations: choose among the yaw hypotheses (and order
    /// RegistrationResult::hypotheses) by the share of source points in each pass's RANSAC
    /// consensus, each hypothesis's pose being its consensus pose (true), or by the fitness of
    /// their poses, the consensus pose replacing the weighted SVD's only when fitter (false). The
    /// fitness rewards any pose that puts points near points, also a street seen turned round; the
    /// consensus asks that the network's own matches agree on the pose. Without RANSAC the fitness
    /// chooses.
    bool select_by_consensus = true;
    /// Several yaw hypotheses: the start's own heading (hypothesis 0) is kept unless another
    /// hypothesis scores more than this factor times its score (1 = no preference). A caller
    /// that has a start, as odometry between consecutive sweeps has, knows the heading is near
    /// it more often than not; a street or a corridor turned round can score as well as the
    /// right heading, a revisit from the other direction scores far more.
    double start_heading_margin = 1.0;
    /// With select_by_consensus: when fewer than this share of the source points agree with the
    /// chosen hypothesis's consensus pose, the start is returned instead (kept_start; 0 = off).
    /// Where the network's matches scatter (sweeps far apart with little in common), the best of
    /// the hypotheses is as likely a street turned round as the right pose, and the start, for
    /// odometry the motion so far, is the better guess.
    double min_consensus = 0.0;
    /// Refine the chosen pose as the self-training teacher labels a pair (teacherLabels with
    /// `teacher`: ICP on the network's sampled, normalised points, from the network's pose and
    /// from the identity, the start that aligns more points kept). Measures on benchmark pairs
    /// what training hands the network; off by default.
    bool teacher_refine = false;
    TeacherParams teacher{};
  };

  /// Loads the model. A missing, corrupt or mismatched file throws IoError / FormatError naming it.
  explicit ObmNetRegistrar(const Options& options);
  ~ObmNetRegistrar();
  ObmNetRegistrar(ObmNetRegistrar&&) noexcept;
  ObmNetRegistrar& operator=(ObmNetRegistrar&&) noexcept;

  /// Registers `source` onto `target`: samples num_points of each (all if fewer), normalises the
  /// pair exactly as in training, runs the network, and maps the pose back to the input frames.
  /// Throws ContractError when a cloud has fewer points than the network's neighbourhoods need.
  RegistrationResult align(const PointCloud& source, const PointCloud& target) const;

  /// Human-readable summary of the loaded model (config and description).
  std::string describe() const;
  /// Points per cloud used by align().
  int numPoints() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace obm::obmnet
