#pragma once
/// \file params.hpp
/// Parameters of the scan matchers: point-to-plane ICP (IcpParams) and the confidence model
/// (ConfidenceParams). Plain structs with in-class defaults (tuned for voxelised LiDAR scans in
/// metres); each is loaded from YAML in exactly one place, its `load`. See docs/registration.md
/// and config/registration/*.yaml.
#include <cstdint>
#include <string>

#include "obm/registration/prepared_target.hpp"
#include "obm/registration/robust_kernel.hpp"

namespace obm {
class ConfigNode;
}  // namespace obm

namespace obm::registration {

/// Residual of one correspondence.
enum class IcpMetric {
  PointToPlane,  ///< r = nᵀ(T·p − q) with the target normal n (Chen & Medioni 1992)
  PointToPoint,  ///< r = T·p − q (Besl & McKay 1992)
};

/// Normal-equation solver of one ICP iteration.
enum class IcpSolver {
  GaussNewton,         ///< δ = −(H + εI)⁻¹g, always accepted
  LevenbergMarquardt,  ///< δ = −(H + λ·diag H)⁻¹g, accepted only when the robust cost decreases
};

/// Point-to-plane ICP (and the residual model used to evaluate any alignment).
struct IcpParams {
  // --- preprocessing -------------------------------------------------------------------------
  double source_voxel = 0.0;    ///< [m] voxel down-sampling of the source before matching; 0 = off
  double target_voxel = 0.0;    ///< [m] voxel down-sampling of the target (PreparedTarget); 0 = off
  int normal_neighbors = 15;    ///< k nearest neighbours of the target's PCA normals
  double min_planarity = 0.05;  ///< normals of less planar neighbourhoods are not trusted [-]

  // --- correspondences -----------------------------------------------------------------------
  /// [m] final (fine) gate: a source point pairs with its nearest target point only within this.
  double max_correspondence_distance = 1.0;
  /// [m] coarse gate the iterations start from (annealing); 0 = start at the fine gate. Each time
  /// the iterations settle, the gate shrinks by `anneal_factor` until it reaches the fine one.
  double initial_max_correspondence_distance = 0.0;
  double anneal_factor = 0.5;  ///< gate multiplier per annealing stage, in (0, 1)
  /// [m] point-to-point polish after the point-to-plane run (0 = off): the pose is refined once
  /// more with r = T·p − q, the gate annealed from `max_correspondence_distance` down to this.
  /// PCA normals of jittered clouds tilt with the noise and move the point-to-plane minimum. When
  /// both clouds carry the *same* surface samples with independent jitter (RIENet's object
  /// protocols: the source is the target's points moved, cropped and jittered), the
  /// point-to-point minimum is the true pose and the polish removes that drift (partial_noise,
  /// ICP started at the true pose: 69.5 % → 95.5 % recall, docs/benchmarks.md). When each cloud
  /// samples the surface on its own (LiDAR sweeps, RGB-D frames), nearest points are different
  /// points and the polish is worse: off by default (tests/registration: both cases).
  double polish_max_correspondence_distance = 0.0;

  // --- cost ----------------------------------------------------------------------------------
  IcpMetric metric = IcpMetric::PointToPlane;
  /// With point-to-plane: where the target normal is not trusted, use the point-to-point residual
  /// instead of dropping the correspondence.
  bool point_to_point_fallback = true;
  RobustKernel kernel = RobustKernel::Huber;
  double kernel_scale = 0.1;  ///< [m] scale c of the robust kernel
  /// [m] a last stage at the fine gate with this kernel scale (0 = none): once the iterations
  /// settle at the fine gate, they continue with c = final_kernel_scale. The wide kernel keeps
  /// the basin of the coarse stages; a kernel near the noise level then down-weights the pairs
  /// that independent samplings and partial overlaps leave a few spacings off, which pull the
  /// minimum (objects: ICP started at the true pose keeps 81.2 % of 144 validation pairs within
  /// 1° / 0.01 with c = 0.02 alone, 84.0 % with a last stage at c = 0.005; docs/benchmarks.md).
  double final_kernel_scale = 0.0;
  /// Directions of the pose the residuals hardly constrain are not moved (0 = off): each
  /// iteration, the eigenvectors of the unit-free Hessian (rotation scaled by the RMS lever arm
  /// of the paired points, per correspondence, as the conditioning score of confidence.hpp)
  /// whose eigenvalue is below this are left out of the step. A flat plate's in-plane slide
  /// and turn, a cylinder's slide along its axis: there the noise-tilted normals have a small,
  /// biased pull and nothing resists it, so the iterations walk off the start. [-]
  double weak_direction_threshold = 0.0;
  /// Weight λ of the photometric term of coloured ICP (Park, Zhou & Koltun 2017): the cost is
  /// E_geometric + λ·E_colour, with the colour residual r = I(q) + d_qᵀ(T·p − q) − I(p) on the
  /// target's tangent-plane intensity gradient d_q (docs/registration.md, "Coloured ICP"). Used
  /// only when both clouds carry colours; 0 = geometric ICP. The paper's σ = 0.968 of
  /// (1 − σ)·E_C + σ·E_G is λ = (1 − σ)/σ ≈ 0.033. [-]
  double color_weight = 0.0;
  double color_kernel_scale = 0.1;  ///< scale of the robust kernel of the colour residual [0-1]
  /// Weights of an RGB-D source by the axial noise of structured-light depth (Nguyen, Izadi &
  /// Lovell 2012): σ(z) = a + b·(z − z₀)² with z the point's depth (its z in the camera's optical
  /// frame), w = (σ(1 m)/σ(z))², so far points, whose depth is several times noisier, pull less.
  /// For sources in an optical frame only (z forward); off for LiDAR.
  bool depth_noise_weights = false;
  double depth_noise_a = 0.0012;   ///< [m] a (Kinect v1)
  double depth_noise_b = 0.0019;   ///< [1/m] b
  double depth_noise_z0 = 0.4;     ///< [m] z₀

  // --- solver --------------------------------------------------------------------------------
  IcpSolver solver = IcpSolver::LevenbergMarquardt;
  int max_iterations = 50;              ///< correspondence-search iterations (all stages)
  double translation_tolerance = 1e-4;  ///< [m] converged when the step is below this ...
  double rotation_tolerance = 1e-4 * 0.017453292519943295;  ///< [rad] ... and this (YAML: _deg)
  int min_correspondences = 30;  ///< fewer points or correspondences is an expected failure
  int threads = 2;               ///< correspondence-search threads (results do not depend on it)

  /// The PreparedTarget options these parameters imply.
  PreparedTarget::Options targetOptions() const;
  /// Throws ContractError naming the first out-of-range value.
  void validate() const;
  /// Reads the keys of `node` (all optional; unknown keys rejected; `rotation_tolerance_deg` in
  /// degrees; `kernel`, `metric`, `solver` by name) and validates. Throws ConfigError naming
  /// file and key.
  static IcpParams load(const ConfigNode& node);
};

/// Confidence of a match: information matrix and scalar quality (docs/registration.md).
struct ConfidenceParams {
  /// [m] a correspondence whose residual is within this counts as an inlier (inlier_ratio).
  double inlier_threshold = 0.2;
  /// [grey level, 0-1] on coloured pairs, an inlier also needs its coloured-ICP grey residual
  /// |I(q) + d_qᵀ(T·p − q) − I(p)| within this (0 = geometric inliers only). Used only where the
  /// photometric term is (IcpParams::color_weight > 0, both clouds coloured). A pose slid along a
  /// wall or floor pairs as many points within a few centimetres as the right one, sometimes more,
  /// but the texture it lays on the target does not match (docs/registration.md, "Coloured
  /// inliers").
  double color_inlier_threshold = 0.0;
  /// [m] floor of the residual standard deviation σ, so that a noise-free (or over-fitted)
  /// match does not produce an unbounded information matrix.
  double min_sigma = 0.005;
  /// Multiplies Ω. Residuals of neighbouring points are correlated, which the textbook Ω = H/σ²
  /// ignores (it is over-confident for dense scans); a back-end may want < 1. [-]
  double information_scale = 1.0;
  /// Quality: inlier_ratio at or above this gets full credit. [-]
  double inlier_ratio_ref = 0.5;
  /// Quality: overlap at or above this gets full credit. [-]
  double overlap_ref = 0.5;
  /// Quality: normalised smallest Hessian eigenvalue at or above this gets full credit. [-]
  double conditioning_ref = 0.02;
  /// Status Degenerate when the normalised smallest Hessian eigenvalue is below this. [-]
  double degeneracy_threshold = 1e-3;

  /// Throws ContractError naming the first out-of-range value.
  void validate() const;
  /// Reads the keys of `node` (all optional; unknown keys rejected) and validates.
  static ConfidenceParams load(const ConfigNode& node);
};

/// Parses "point_to_plane" / "point_to_point"; throws ConfigError prefixed with `where`.
IcpMetric parseIcpMetric(const std::string& name, const std::string& where = "metric");
std::string toString(IcpMetric metric);
/// Parses "gauss_newton" / "levenberg_marquardt" (or "gn" / "lm").
IcpSolver parseIcpSolver(const std::string& name, const std::string& where = "solver");
std::string toString(IcpSolver solver);

}  // namespace obm::registration
