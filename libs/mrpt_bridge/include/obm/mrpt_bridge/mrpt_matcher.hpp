#pragma once
/// \file mrpt_matcher.hpp
/// obmslam's scan matchers (ICP, OBMNet, OBMNet + ICP, OBMM + ICP) for MRPT users: MRPT point maps
/// or observations in, an mrpt::poses::CPose3DPDFGaussian out, in the argument order of MRPT's
/// own mrpt::slam::CICP::Align3DPDF(m1, m2, initial): the pose of m2 in the frame of m1.
/// \code
///   obm::ScanMatcherConfig cfg;               // or ScanMatcherConfig::load(yaml), e.g. the
///   cfg.type = obm::MatcherKind::Icp;         // `matcher:` of config/presets/lidar.yaml
///   obm::mrpt_bridge::MrptScanMatcher matcher(cfg);
///   auto r = matcher.align(map1, map2);       // r.pose: CPose3DPDFGaussian of map2 in map1
///   if (r.match.ok()) use(r.pose.mean, r.pose.cov);
/// \endcode
#include <memory>

#include <mrpt/maps/CPointsMap.h>
#include <mrpt/obs/CObservation.h>
#include <mrpt/poses/CPose3D.h>
#include <mrpt/poses/CPose3DPDFGaussian.h>

#include "obm/registration/factory.hpp"
#include "obm/registration/match_result.hpp"
#include "obm/registration/scan_matcher.hpp"

namespace obm::mrpt_bridge {

class MrptScanMatcher {
 public:
  /// The matcher `config` describes (makeScanMatcher: loads the model for the OBMNet types).
  explicit MrptScanMatcher(const registration::ScanMatcherConfig& config);
  /// Wraps an existing matcher.
  explicit MrptScanMatcher(std::unique_ptr<registration::ScanMatcher> matcher);

  struct Result {
    /// Mean: the pose of m2 in m1's frame (T_m1_m2, i.e. T_target_source with target = m1);
    /// covariance from the match's information matrix (toPose3DPDFGaussian).
    mrpt::poses::CPose3DPDFGaussian pose;
    /// Everything the matcher reports: status, inlier ratio, fitness, quality, the network's
    /// bias α and confidence, the information matrix in obmslam's convention.
    registration::MatchResult match;
  };

  /// Registers point map m2 onto m1, starting from `initial` (the pose of m2 in m1; identity when
  /// unknown). Expected failures come back in `match.status`, as for ScanMatcher::match.
  Result align(const mrpt::maps::CPointsMap& m1, const mrpt::maps::CPointsMap& m2,
               const mrpt::poses::CPose3D& initial = mrpt::poses::CPose3D()) const;
  /// Registers two observations (their points in their robots' frames): the pose of the robot of
  /// o2 in the frame of the robot of o1.
  Result align(const mrpt::obs::CObservation& o1, const mrpt::obs::CObservation& o2,
               const mrpt::poses::CPose3D& initial = mrpt::poses::CPose3D()) const;

  const registration::ScanMatcher& matcher() const { return *matcher_; }

 private:
  std::unique_ptr<registration::ScanMatcher> matcher_;
};

}  // namespace obm::mrpt_bridge
