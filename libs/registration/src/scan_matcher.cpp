#include "obm/registration/scan_matcher.hpp"

#include <cmath>

#include "obm/core/cloud_ops.hpp"
#include "obm/core/errors.hpp"
#include "obm/core/timer.hpp"

namespace obm::registration {
namespace {

bool allFinite(const PointCloud& c) {
  for (const auto& p : c.points)
    if (!p.allFinite()) return false;
  return true;
}

MatchResult failure(MatchStatus status, std::string message, const Isometry3d& T) {
  MatchResult r;
  r.T_target_source = T;
  r.status = status;
  r.message = std::move(message);
  return r;
}

}  // namespace

ScanMatcher::ScanMatcher(const IcpParams& icp, const ConfidenceParams& confidence)
    : icp_(icp), confidence_(confidence) {
  icp_.validate();
  confidence_.validate();
}

ScanMatcher::~ScanMatcher() = default;

PreparedTarget ScanMatcher::prepare(const PointCloud& target) const {
  return PreparedTarget(target, icp_.targetOptions());
}

MatchResult ScanMatcher::match(const PointCloud& source, const PointCloud& target,
                               const Isometry3d& T_target_source_init) const {
  Timer timer;
  OBM_ASSERT(T_target_source_init.matrix().allFinite(),
             "ScanMatcher::match: the initial guess T_target_source is not finite");
  const PreparedTarget prepared = prepare(target);
  MatchResult r = match(source, prepared, T_target_source_init);
  r.runtime_ms = timer.ms();
  return r;
}

MatchResult ScanMatcher::match(const PointCloud& source, const PreparedTarget& target,
                               const Isometry3d& T_target_source_init) const {
  Timer timer;
  OBM_ASSERT(T_target_source_init.matrix().allFinite(),
             "ScanMatcher::match: the initial guess T_target_source is not finite");
  MatchResult r;
  // Only copy the source when it must change (non-finite points or voxelisation).
  PointCloud cleaned;
  const PointCloud* src = &source;
  if (!allFinite(source)) {
    cleaned = source;
    cleaned.removeNonFinite();
    src = &cleaned;
  }
  if (icp_.source_voxel > 0.0) {
    cleaned = voxelDownsample(*src, icp_.source_voxel);
    src = &cleaned;
  }
  const auto min_points = static_cast<std::size_t>(icp_.min_correspondences);
  if (src->empty()) {
    r = failure(MatchStatus::EmptyInput, "the source cloud has no finite point",
                T_target_source_init);
  } else if (target.empty()) {
    r = failure(MatchStatus::EmptyInput, "the target cloud has no finite point",
                T_target_source_init);
  } else if (src->size() < min_points || target.size() < min_points) {
    r = failure(MatchStatus::TooFewPoints,
                "source has " + std::to_string(src->size()) + " and target " +
                    std::to_string(target.size()) + " points (need " + std::to_string(min_points) +
                    " each)",
                T_target_source_init);
  } else {
    r = impl_match(*src, target, T_target_source_init);
  }
  r.runtime_ms = timer.ms();
  return r;
}

}  // namespace obm::registration
