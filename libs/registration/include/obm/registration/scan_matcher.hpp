#pragma once
/// \file scan_matcher.hpp
/// The scan-matcher interface (mp2p_icp style): a public non-virtual match() that validates and
/// pre-processes the input, times the call and then delegates to the protected virtual
/// impl_match() of the concrete matcher (IcpMatcher, ObmNetMatcher, ObmNetIcpMatcher).
#include <memory>
#include <string>

#include "obm/core/point_cloud.hpp"
#include "obm/core/se3.hpp"
#include "obm/registration/match_result.hpp"
#include "obm/registration/params.hpp"
#include "obm/registration/prepared_target.hpp"

namespace obm::registration {

class ScanMatcher {
 public:
  virtual ~ScanMatcher();
  ScanMatcher(const ScanMatcher&) = delete;
  ScanMatcher& operator=(const ScanMatcher&) = delete;

  /// Short name: "icp", "obmnet", "obmnet+icp".
  virtual std::string name() const = 0;
  /// True when the matcher can register without a good initial guess (OBMNet's learned
  /// correspondences); false for local methods (ICP).
  virtual bool global() const { return false; }

  /// Builds the reusable target structure (down-sampling, KD-tree, normals) with this matcher's
  /// settings. Match many sources against it with the overload below.
  PreparedTarget prepare(const PointCloud& target) const;

  /// Registers `source` onto `target` starting from `T_target_source_init` (the constant-velocity
  /// guess for odometry, identity when unknown). Expected failures (empty clouds, too few
  /// points/correspondences, no convergence, degenerate geometry) come back as a status; throws
  /// ContractError only for a non-finite initial guess.
  MatchResult match(const PointCloud& source, const PointCloud& target,
                    const Isometry3d& T_target_source_init = Isometry3d::Identity()) const;

  /// Same against a prepared target (built by prepare() or with equivalent options).
  MatchResult match(const PointCloud& source, const PreparedTarget& target,
                    const Isometry3d& T_target_source_init = Isometry3d::Identity()) const;

  const IcpParams& icpParams() const { return icp_; }
  const ConfidenceParams& confidenceParams() const { return confidence_; }

 protected:
  ScanMatcher(const IcpParams& icp, const ConfidenceParams& confidence);

  /// The matcher proper. `source` is finite, voxelised by icp.source_voxel and has at least
  /// icp.min_correspondences points; `target` likewise. Fill everything but runtime_ms.
  virtual MatchResult impl_match(const PointCloud& source, const PreparedTarget& target,
                                 const Isometry3d& T_target_source_init) const = 0;

  IcpParams icp_;
  ConfidenceParams confidence_;
};

}  // namespace obm::registration
