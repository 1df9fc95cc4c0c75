#include "tracker.hpp"

#include <algorithm>
#include <cmath>
#include <string>
#include <utility>
#include <vector>

#include "obm/frontend/stages.hpp"
#include "obm/core/log.hpp"

namespace obm::frontend {

Rejection checkAcceptance(const registration::MatchResult& r, const Isometry3d& T_guess,
                          const AcceptanceBounds& bounds) {
  using K = RejectionKind;
  if (r.status != registration::MatchStatus::Ok &&
      r.status != registration::MatchStatus::NotConverged &&
      r.status != registration::MatchStatus::Degenerate)
    return {K::MatchStatus, std::string("match status ") + toString(r.status) +
                                (r.message.empty() ? "" : " (" + r.message + ")")};
  if (!r.T_target_source.matrix().allFinite()) return {K::NonFinitePose, "non-finite pose"};
  if (r.quality < bounds.min_quality)
    return {K::Quality,
            "quality " + std::to_string(r.quality) + " < " + std::to_string(bounds.min_quality)};
  if (r.inlier_ratio < bounds.min_inlier_ratio)
    return {K::InlierRatio, "inlier ratio " + std::to_string(r.inlier_ratio) + " < " +
                                std::to_string(bounds.min_inlier_ratio) +
                                " (recent frames fit better)"};
  const Isometry3d delta = T_guess.inverse() * r.T_target_source;
  const double dt = delta.translation().norm();
  const double dr = rotationAngle(delta.linear());
  if (dt > bounds.max_correction)
    return {K::TranslationJump, "jump of " + std::to_string(dt) +
                                    " m from the constant-velocity guess (> " +
                                    std::to_string(bounds.max_correction) + " m)"};
  const bool large_turn = bounds.large_turn_min_inlier_ratio > 0.0 &&
                          r.inlier_ratio >= bounds.large_turn_min_inlier_ratio;
  if (dr > bounds.max_rotation && !large_turn)
    return {K::RotationJump, "jump of " + std::to_string(dr * kRadToDeg) +
                                 " deg from the constant-velocity guess (> " +
                                 std::to_string(bounds.max_rotation * kRadToDeg) + " deg)"};
  return Rejection::accepted();
}

Tracker::Tracker(const TrackingParams& params) : params_(params) {
  icp_ = std::make_unique<registration::IcpMatcher>(params.icp, params.confidence);
  if (params.recovery_gate > 0.0) {
    registration::IcpParams r = params.icp;
    r.initial_max_correspondence_distance =
        std::max(params.recovery_gate, r.max_correspondence_distance);
    r.max_iterations = std::max(r.max_iterations, 60);
    wide_gate_ = std::make_unique<registration::IcpMatcher>(r, params.confidence);
  }
}

Rejection Tracker::track(const PointCloud& source, const registration::PreparedTarget& local_map,
                         const Isometry3d& T_guess, bool have_velocity,
                         registration::MatchResult& match, StageTimes& times,
                         const Isometry3d* extra_start) {
  const TrackingParams& tp = params_;
  const double inl_ref = recentInlierRatio();
  AcceptanceBounds bounds;
  bounds.min_quality = tp.min_quality;
  bounds.min_inlier_ratio = tp.relative_inlier_ratio * inl_ref;
  bounds.max_correction = have_velocity ? tp.max_correction : tp.recovery_max_correction;
  bounds.max_rotation =
      have_velocity ? tp.max_correction_rotation : tp.recoveryMaxRotation();
  {
    TimedStage s(times, Stage::Icp);
    if (have_velocity || !wide_gate_)
      match = icp_->match(source, local_map, T_guess);
    else
      match = searchStart(source, local_map, T_guess, bounds, extra_start);
  }
  Rejection reason = checkAcceptance(match, T_guess, bounds);
  if (reason.kind == RejectionKind::InlierRatio && have_velocity &&
      tp.guess_agreement_translation > 0.0) {
    // Fails only the relative inlier ratio (the other tests, with that bound lowered, pass) and
    // agrees with the motion prior: the view moved into unmapped space (TrackingParams).
    AcceptanceBounds lowered = bounds;
    lowered.min_inlier_ratio = tp.guess_agreement_relative_inlier_ratio * inl_ref;
    const Isometry3d d = T_guess.inverse() * match.T_target_source;
    if (!checkAcceptance(match, T_guess, lowered).rejected() &&
        d.translation().norm() <= tp.guess_agreement_translation &&
        rotationAngle(d.linear()) <= tp.guess_agreement_rotation)
      reason = Rejection::accepted();
  }
  if (!reason.rejected()) {
    recent_inliers_.push_back(match.inlier_ratio);
    if (recent_inliers_.size() > 10) recent_inliers_.pop_front();
  }
  return reason;
}

registration::MatchResult Tracker::searchStart(const PointCloud& source,
                                               const registration::PreparedTarget& local_map,
                                               const Isometry3d& T_guess,
                                               const AcceptanceBounds& bounds,
                                               const Isometry3d* extra_start) const {
  std::vector<std::pair<Isometry3d, std::string>> starts;
  const double step = params_.start_search_step;
  const auto k_max = static_cast<int>(std::floor(params_.start_search_range / step + 1e-9));
  for (int k = 1; k <= k_max; ++k) {
    for (const int sign : {1, -1}) {
      Isometry3d T_start = T_guess;
      T_start.translate(sign * k * step * params_.start_search_axis);
      starts.emplace_back(T_start, std::to_string(sign * k * step) + " m");
    }
  }
  if (extra_start) starts.emplace_back(*extra_start, "the scan matcher's pose");

  registration::MatchResult best = wide_gate_->match(source, local_map, T_guess);
  bool best_ok = !checkAcceptance(best, T_guess, bounds).rejected();
  for (const auto& [T_start, what] : starts) {
    registration::MatchResult m = wide_gate_->match(source, local_map, T_start);
    const bool ok = !checkAcceptance(m, T_guess, bounds).rejected();
    OBM_LOG_DEBUG("tracker", "start search from " << what << ": inlier ratio " << m.inlier_ratio
                                                  << (ok ? "" : " (rejected)"));
    // The start that pairs the most points within the inlier threshold; an accepted match
    // always beats a rejected one, and ties keep the earlier start (the last pose first).
    if ((ok && !best_ok) || (ok == best_ok && m.inlier_ratio > best.inlier_ratio)) {
      best = std::move(m);
      best_ok = ok;
    }
  }
  return best;
}

double Tracker::recentInlierRatio() const {
  if (recent_inliers_.empty()) return 0.0;
  std::vector<double> q(recent_inliers_.begin(), recent_inliers_.end());
  std::nth_element(q.begin(), q.begin() + q.size() / 2, q.end());
  return q[q.size() / 2];
}

}  // namespace obm::frontend
