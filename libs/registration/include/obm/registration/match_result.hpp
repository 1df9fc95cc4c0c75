#pragma once
/// \file match_result.hpp
/// What every scan matcher returns: the pose T_target_source, diagnostics, the 6×6 information
/// matrix of the pose and a scalar quality, plus a status for expected failures (no exceptions for
/// those).
///
/// Tangent-space convention of `information`: the pose error is a right (source-frame)
/// perturbation T_target_source = T̂ · Exp(δ), δ = [ρ; θ] ∈ ℝ⁶ ordered [translation; rotation],
/// with ρ [m] and θ the small-angle rotation vector [rad]. This is the frame and order of g2o's
/// EDGE_SE3:QUAT error e = [t; vec(q)] of Z⁻¹·(X_from⁻¹·X_to) for the edge from = target,
/// to = source; g2o's rotation part is vec(q) ≈ θ/2, so feed the back-end
/// informationThetaToG2o(information).
#include <cstddef>
#include <string>

#include "obm/core/se3.hpp"

namespace obm::registration {

/// Outcome class of a match. Everything but Ok is an expected failure, reported, not thrown.
enum class MatchStatus {
  Ok,                     ///< converged, well-conditioned
  EmptyInput,             ///< source or target has no (finite) point
  TooFewPoints,           ///< fewer points than the matcher needs (min_correspondences, network)
  TooFewCorrespondences,  ///< too few source points found a target partner within the gate
  NotConverged,           ///< iteration limit reached; the pose is the last iterate
  Degenerate,             ///< the geometry leaves a direction unconstrained (see information)
};

/// "ok", "empty_input", "too_few_points", "too_few_correspondences", "not_converged",
/// "degenerate".
const char* toString(MatchStatus status);

/// Where the refinement of the returned pose started. Whether the network's own pose was the one
/// taken is what a ledger of the network's use counts (obm-map's metrics.json, "matcher_ledger").
enum class MatchStart {
  Guess,       ///< the caller's initial guess (ICP; OBMNet + ICP when the guess paired more)
  Network,     ///< the network's pose (its first hypothesis, also from a turned start)
  Hypothesis,  ///< another of the network's yaw hypotheses
  Heading,     ///< a blind heading turned from the guess
  Turn,        ///< a start turned from the guess, kept over the network's pose from it
  Search,      ///< a pose of the correlative search
};

/// "guess", "network", "hypothesis", "heading", "turn", "search".
const char* toString(MatchStart start);

/// True for the starts that are the network's poses (Network, Hypothesis).
inline bool fromNetwork(MatchStart start) {
  return start == MatchStart::Network || start == MatchStart::Hypothesis;
}

/// Result of ScanMatcher::match.
struct MatchResult {
  Isometry3d T_target_source = Isometry3d::Identity();  ///< p_target = T · p_source
  MatchStatus status = MatchStatus::Ok;
  std::string message;     ///< what went wrong (empty when Ok)
  bool converged = false;  ///< the iterative refinement met its tolerances (OBMNet alone: true)
  int iterations = 0;      ///< ICP iterations (0 for OBMNet alone)
  std::size_t num_correspondences = 0;  ///< source points paired within the fine gate
  /// Fraction of (down-sampled) source points whose residual at the solution is within
  /// ConfidenceParams::inlier_threshold. [0, 1]
  double inlier_ratio = 0.0;
  double rmse = 0.0;   ///< [m] RMS residual of the correspondences at the solution (unweighted)
  /// Fraction of (down-sampled) source points with a target partner within the fine gate at the
  /// solution: ICP's own fitness score (Open3D's `fitness`). [0, 1]
  double fitness = 0.0;
  /// OBMNet matchers: the bias-weighted confidence of the pair, Σ ω_i·[r_i ≤ inlier_threshold] /
  /// Σ ω_i over the network's sampled source points at the solution, with the network's SVD
  /// weights ω_i = w_i·(1 + α·m_i) (inlier weight, bias α, overlap membership). It trusts the
  /// points the network placed in the overlap: a pose that pairs only the points it called
  /// outliers scores low. −1 when no network was involved. [0, 1]
  double network_confidence = -1.0;
  double alpha = 1.0;  ///< OBMNet's bias coefficient α; 1 when no network was involved
  /// Overlap estimate in [0, 1]: the network's for the OBMNet matchers, else the fraction of
  /// source points with a correspondence.
  double overlap = 0.0;
  /// 6×6 information Ω = H/σ² of the pose, ordered [translation; rotation] in the right
  /// (source-frame) small-angle twist coordinates described in the file comment.
  Matrix6d information = Matrix6d::Zero();
  double sigma = 0.0;  ///< [m] residual standard deviation σ used in Ω (after the floor)
  /// Normalised smallest eigenvalue of H over every source point at the solution, whichever
  /// matcher (0 = degenerate; ~0.1 for a box seen from inside).
  double conditioning = 0.0;
  /// Scalar in [0, 1] from inlier ratio, rmse, fitness and conditioning at the solution, over
  /// every source point: the same function of the pose for every matcher, so one threshold
  /// rejects bad matches of any of them. The network's own view is `network_confidence`.
  double quality = 0.0;
  double runtime_ms = 0.0;  ///< wall time of match() including preprocessing
  MatchStart start = MatchStart::Guess;  ///< where the refinement of T_target_source started

  bool ok() const { return status == MatchStatus::Ok; }
};

/// Converts an information matrix over (t, θ) (this library's convention) into g2o's
/// EDGE_SE3:QUAT parametrisation (t, vec(q)). With θ = 2·vec(q) to first order, the Jacobian is
/// J = ∂(t, θ)/∂(t, vec q) = diag(I₃, 2·I₃) and Ω_q = Jᵀ·Ω_θ·J: the rotation block is multiplied
/// by 4, the cross blocks by 2. Exact in floating point (powers of two).
Matrix6d informationThetaToG2o(const Matrix6d& omega_theta);

/// Inverse of informationThetaToG2o: Ω_θ = J⁻ᵀ·Ω_q·J⁻¹.
Matrix6d informationG2oToTheta(const Matrix6d& omega_q);

}  // namespace obm::registration
