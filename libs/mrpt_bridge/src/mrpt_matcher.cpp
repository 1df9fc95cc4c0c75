#include "obm/mrpt_bridge/mrpt_matcher.hpp"

#include "obm/core/errors.hpp"
#include "obm/mrpt_bridge/conversions.hpp"

namespace obm::mrpt_bridge {

MrptScanMatcher::MrptScanMatcher(const registration::ScanMatcherConfig& config)
    : matcher_(registration::makeScanMatcher(config)) {}

MrptScanMatcher::MrptScanMatcher(std::unique_ptr<registration::ScanMatcher> matcher)
    : matcher_(std::move(matcher)) {
  if (!matcher_) throw ContractError("MrptScanMatcher: no matcher");
}

namespace {
MrptScanMatcher::Result finish(registration::MatchResult m) {
  MrptScanMatcher::Result r;
  r.pose = toPose3DPDFGaussian(m.T_target_source, m.information);
  r.match = std::move(m);
  return r;
}
}  // namespace

MrptScanMatcher::Result MrptScanMatcher::align(const mrpt::maps::CPointsMap& m1,
                                               const mrpt::maps::CPointsMap& m2,
                                               const mrpt::poses::CPose3D& initial) const {
  // m1 is the reference (target), m2 is registered onto it (source), as in CICP::Align3DPDF.
  return finish(matcher_->match(toPointCloud(m2), toPointCloud(m1), fromCPose3D(initial)));
}

MrptScanMatcher::Result MrptScanMatcher::align(const mrpt::obs::CObservation& o1,
                                               const mrpt::obs::CObservation& o2,
                                               const mrpt::poses::CPose3D& initial) const {
  return finish(matcher_->match(observationToPointCloud(o2), observationToPointCloud(o1),
                                fromCPose3D(initial)));
}

}  // namespace obm::mrpt_bridge
