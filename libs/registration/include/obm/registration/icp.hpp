#pragma once
/// \file icp.hpp
/// Robust point-to-plane ICP on SE(3) (docs/registration.md, "ICP"): nearest-neighbour
/// correspondences within an (optionally annealed) gate, target normals by PCA, an M-estimator
/// kernel by iteratively re-weighted least squares, Gauss–Newton or Levenberg–Marquardt steps.
/// Deterministic: the same input gives the same pose bit for bit, whatever the thread count.
#include <cstddef>
#include <string>
#include <vector>

#include "obm/registration/confidence.hpp"
#include "obm/registration/scan_matcher.hpp"

namespace obm::registration {

/// The bare ICP iterations (no confidence), for matchers that refine another estimate.
struct IcpOutcome {
  Isometry3d T_target_source = Isometry3d::Identity();
  MatchStatus status = MatchStatus::Ok;  ///< Ok, TooFewCorrespondences or NotConverged
  std::string message;
  bool converged = false;
  int iterations = 0;                   ///< correspondence searches done
  std::size_t num_correspondences = 0;  ///< at the last iteration

  /// A MatchResult with this outcome's pose, status, message, convergence, iterations and
  /// correspondences (the confidence is left to the matcher).
  MatchResult toMatchResult() const {
    MatchResult r;
    r.T_target_source = T_target_source;
    r.status = status;
    r.message = message;
    r.converged = converged;
    r.iterations = iterations;
    r.num_correspondences = num_correspondences;
    return r;
  }
};

/// Runs ICP of `source_points` (source frame, finite) onto `target` from `T_target_source_init`.
/// `point_weights` (optional, one ≥ 0 per source point) scale each point's robust residual: e.g.
/// the Overlap Bias Matching Module's ω_i = w_i·(1 + α·m_i), so that the points predicted
/// outside the overlap pull less. `source_intensity` (optional, colorIntensity() per source point)
/// turns on coloured ICP's photometric term when IcpParams::color_weight > 0 and the target has
/// colour gradients (PreparedTarget::Options::color_gradients). Throws ContractError when the
/// sizes differ.
IcpOutcome runIcp(const std::vector<Vector3f>& source_points, const PreparedTarget& target,
                  const Isometry3d& T_target_source_init, const IcpParams& params,
                  const std::vector<double>* point_weights = nullptr,
                  const std::vector<float>* source_intensity = nullptr);

/// The source's grey levels for coloured ICP (colorIntensity() per point): empty, so that the ICP
/// stays geometric, unless IcpParams::color_weight > 0, the source carries colours and the target
/// was prepared with colour gradients. Shared by every matcher that refines the whole source.
std::vector<float> colorIntensities(const PointCloud& source, const PreparedTarget& target,
                                    const IcpParams& params);

/// ICP from the initial guess alone, with the confidence of the solution.
class IcpMatcher : public ScanMatcher {
 public:
  /// Validates the parameters (ContractError naming the bad one).
  explicit IcpMatcher(const IcpParams& icp = IcpParams(),
                      const ConfidenceParams& confidence = ConfidenceParams());
  std::string name() const override { return "icp"; }

 protected:
  MatchResult impl_match(const PointCloud& source, const PreparedTarget& target,
                         const Isometry3d& T_target_source_init) const override;
};

/// Fills the confidence fields of `result` (information, sigma, conditioning, quality,
/// inlier_ratio, rmse, num_correspondences, and overlap when `set_overlap`) from `all_stats`
/// (every source point, unit prior weights) and `info_stats` (the points the information is
/// built from; may be the same), and turns an Ok status into Degenerate / TooFewCorrespondences
/// when the statistics say so. Only the information and sigma come from `info_stats`: the
/// conditioning, the degeneracy and the quality are taken on every source point, so they are the
/// same function of the pose for every matcher. Shared by the matchers.
void applyConfidence(MatchResult& result, const AlignmentStats& all_stats,
                     const AlignmentStats& info_stats, bool set_overlap, const IcpParams& icp,
                     const ConfidenceParams& confidence);

}  // namespace obm::registration
