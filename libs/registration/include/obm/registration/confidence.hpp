#pragma once
/// \file confidence.hpp
/// Confidence of an alignment (docs/registration.md, "Confidence"): the Gauss–Newton Hessian of
/// the weighted point-to-plane cost at the solution, the residual variance, the information
/// Ω = H/σ², and the scalar quality used to reject bad matches.
#include <cstddef>
#include <vector>

#include "obm/core/point_cloud.hpp"
#include "obm/core/se3.hpp"
#include "obm/registration/params.hpp"
#include "obm/registration/prepared_target.hpp"

namespace obm::registration {

/// Residual statistics of source points against a prepared target at a pose.
struct AlignmentStats {
  std::size_t num_points = 0;           ///< source points evaluated
  std::size_t num_correspondences = 0;  ///< points with a target partner within the fine gate
  /// Correspondences with |r| <= inlier_threshold (and, with a source_intensity and
  /// ConfidenceParams::color_inlier_threshold, a grey residual within that).
  std::size_t num_inliers = 0;
  double overlap = 0.0;                 ///< num_correspondences / num_points
  double inlier_ratio = 0.0;            ///< num_inliers / num_points
  double rmse = 0.0;         ///< [m] RMS of the unweighted residual norms of the correspondences
  double weight_sum = 0.0;   ///< Σ ω_i m_i (m_i = residual dimension: 1 plane, 3 point)
  double sigma2 = 0.0;       ///< [m²] Σ ω_i ‖r_i‖² / (Σ ω_i m_i − 6), before the floor
  double sigma2_used = 0.0;  ///< [m²] max(sigma2, min_sigma²)
  /// H = Σ ω_i J_iᵀ J_i, right (source-frame) perturbation, [translation; rotation].
  Matrix6d hessian = Matrix6d::Zero();
  Matrix6d information = Matrix6d::Zero();  ///< information_scale · H / σ²_used
  /// Smallest eigenvalue of D·H·D / Σω with D = diag(1, 1, 1, 1/L, 1/L, 1/L), L the RMS
  /// distance of the paired source points from the source origin: unit-free, in [0, 1].
  double conditioning = 0.0;
  bool valid = false;  ///< Σ ω_i m_i > 6: enough weighted residuals for σ²
};

/// Evaluates source points (source frame) against `target` at `T_target_source` with the
/// residual model of `icp` (fine gate, metric, fallback, kernel) and per-point prior weights
/// `point_weights` (nullptr = all 1; else one per point, >= 0). ω_i = point_weight_i ·
/// robust_weight(r_i). Deterministic and independent of icp.threads. With `source_intensity`
/// (colorIntensity() per point), IcpParams::color_weight > 0 and target colour gradients, the
/// conditioning is taken on the Hessian of the coloured-ICP cost (geometric + photometric), so a
/// textured plane is not reported degenerate, and ConfidenceParams::color_inlier_threshold (if
/// set) asks the inliers to agree in grey level too; the Hessian and information stay geometric.
AlignmentStats evaluateAlignment(const std::vector<Vector3f>& source_points,
                                 const std::vector<double>* point_weights,
                                 const PreparedTarget& target, const Isometry3d& T_target_source,
                                 const IcpParams& icp, const ConfidenceParams& confidence,
                                 const std::vector<float>* source_intensity = nullptr);

/// Whether the coloured-inlier rule applies (ConfidenceParams::color_inlier_threshold): a
/// threshold set, coloured ICP's photometric term on (IcpParams::color_weight > 0), the target
/// prepared with colour gradients and grey levels for the source points. The one test of
/// evaluateAlignment's inliers and of the OBMNet matchers' bias-weighted confidence.
bool colorInliersApply(const IcpParams& icp, const ConfidenceParams& confidence,
                       const PreparedTarget& target, bool source_has_intensity);

/// Scalar quality in [0, 1]:
///   q = min(1, inlier_ratio/ρ_ref) · max(0, 1 − rmse/d_max) · min(1, overlap/o_ref)
///       · min(1, conditioning/λ_ref)
/// with d_max the fine correspondence gate.
double matchQuality(double inlier_ratio, double rmse, double overlap, double conditioning,
                    double max_correspondence_distance, const ConfidenceParams& confidence);

/// Standard deviation [m] of the translation along its least-constrained direction: the square
/// root of the largest eigenvalue of the translation block of Ω⁻¹ (rotation marginalised, so a
/// direction that only a rotation can explain counts as unconstrained). A sweep in a straight
/// corridor of plain walls has a large value along the corridor: ICP's translation there comes
/// from the start pose, not from the geometry (a slide). `direction` (optional) gets the unit
/// direction in the source frame. +∞ for a singular or non-finite Ω.
double weakestTranslationSigma(const Matrix6d& information, Eigen::Vector3d* direction = nullptr);

}  // namespace obm::registration
