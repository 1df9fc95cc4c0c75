#include "tracker.hpp"

#include <algorithm>
#include <vector>

namespace obm::frontend {

std::string rejectReason(const MatchResult& r, const Isometry3d& T_guess,
                         const AcceptanceBounds& bounds) {
  if (r.status != MatchStatus::Ok && r.status != MatchStatus::NotConverged &&
      r.status != MatchStatus::Degenerate)
    return std::string("match status ") + toString(r.status) +
           (r.message.empty() ? "" : " (" + r.message + ")");
  if (!r.T_target_source.matrix().allFinite()) return "non-finite pose";
  if (r.quality < bounds.min_quality)
    return "quality " + std::to_string(r.quality) + " < " + std::to_string(bounds.min_quality);
  if (r.inlier_ratio < bounds.min_inlier_ratio)
    return "inlier ratio " + std::to_string(r.inlier_ratio) + " < " +
           std::to_string(bounds.min_inlier_ratio) + " (recent frames fit better)";
  const Isometry3d delta = T_guess.inverse() * r.T_target_source;
  const double dt = delta.translation().norm();
  const double dr = rotationAngle(delta.linear());
  if (dt > bounds.max_correction)
    return "jump of " + std::to_string(dt) + " m from the constant-velocity guess (> " +
           std::to_string(bounds.max_correction) + " m)";
  if (dr > bounds.max_rotation)
    return "jump of " + std::to_string(dr * kRadToDeg) +
           " deg from the constant-velocity guess (> " +
           std::to_string(bounds.max_rotation * kRadToDeg) + " deg)";
  return {};
}

Tracker::Tracker(const TrackingParams& params) : params_(params) {
  icp_ = std::make_unique<IcpMatcher>(params.icp, params.confidence);
  if (params.recovery_gate > 0.0) {
    IcpParams r = params.icp;
    r.initial_max_correspondence_distance =
        std::max(params.recovery_gate, r.max_correspondence_distance);
    r.max_iterations = std::max(r.max_iterations, 60);
    wide_gate_ = std::make_unique<IcpMatcher>(r, params.confidence);
  }
}

std::string Tracker::track(const PointCloud& source, const PreparedTarget& local_map,
                           const Isometry3d& T_guess, bool have_velocity, MatchResult& match,
                           StageTimes& times) {
  const TrackingParams& tp = params_;
  const double inl_ref = recentInlierRatio();
  {
    ScopedStage s(times, "icp");
    match = (have_velocity || !wide_gate_) ? icp_->match(source, local_map, T_guess)
                                           : wide_gate_->match(source, local_map, T_guess);
  }
  AcceptanceBounds bounds;
  bounds.min_quality = tp.min_quality;
  bounds.min_inlier_ratio = tp.relative_inlier_ratio * inl_ref;
  bounds.max_correction = have_velocity ? tp.max_correction : tp.recovery_max_correction;
  bounds.max_rotation =
      have_velocity ? tp.max_correction_rotation : 4.0 * tp.max_correction_rotation;
  std::string reason = rejectReason(match, T_guess, bounds);
  if (reason.empty()) {
    recent_inliers_.push_back(match.inlier_ratio);
    if (recent_inliers_.size() > 10) recent_inliers_.pop_front();
  }
  return reason;
}

double Tracker::recentInlierRatio() const {
  if (recent_inliers_.empty()) return 0.0;
  std::vector<double> q(recent_inliers_.begin(), recent_inliers_.end());
  std::nth_element(q.begin(), q.begin() + q.size() / 2, q.end());
  return q[q.size() / 2];
}

}  // namespace obm::frontend
