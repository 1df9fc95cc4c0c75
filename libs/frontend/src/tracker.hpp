#pragma once
/// \file tracker.hpp
/// Frame-to-local-map tracking: point-to-plane ICP of the preprocessed sweep against the local map
/// from the constant-velocity guess, and the acceptance tests every registration of a frame
/// passes (tracking, and the recovery steps with their own bounds). Private to libs/frontend.
#include <deque>
#include <memory>
#include <string>

#include "obm/core/point_cloud.hpp"
#include "obm/core/se3.hpp"
#include "obm/core/timer.hpp"
#include "obm/frontend/params.hpp"
#include "obm/frontend/rejection.hpp"
#include "obm/registration/icp.hpp"
#include "obm/registration/match_result.hpp"
#include "obm/registration/prepared_target.hpp"

namespace obm::frontend {

/// The bounds a registration of a frame must meet to be taken.
struct AcceptanceBounds {
  double min_quality = 0.0;       ///< [0, 1]
  double min_inlier_ratio = 0.0;  ///< [0, 1] (a share of the recent median inlier ratio)
  double max_correction = 0.0;    ///< [m] translation of guess⁻¹ · estimate
  double max_rotation = 0.0;      ///< [rad] rotation of guess⁻¹ · estimate
  /// A match whose inlier ratio reaches this [0, 1] may turn beyond max_rotation (0 = never): it
  /// fits as well as the tracked frames, which a wrong minimum degrees away does not.
  double large_turn_min_inlier_ratio = 0.0;
};

/// The first acceptance test the match `r` of a frame whose constant-velocity guess is `T_guess`
/// fails under `bounds` (none when it passes all): status (ok / not_converged / degenerate
/// pass), finite pose, quality, inlier ratio, then the correction of the guess (translation,
/// rotation unless the match qualifies as a large turn).
Rejection checkAcceptance(const registration::MatchResult& r, const Isometry3d& T_guess,
                          const AcceptanceBounds& bounds);

/// Registers every frame against the local map and keeps the recent inlier ratios the relative
/// acceptance test compares with.
class Tracker {
 public:
  explicit Tracker(const TrackingParams& params);

  /// Registers `source` against `local_map` from `T_guess` (stage "icp") into `match`; returns
  /// no rejection when the match is accepted (then its inlier ratio joins the recent ones), else
  /// the test it failed. Without a velocity yet (`have_velocity` false: the second frame) the guess is the
  /// last pose and any motion up to the recovery bound is normal: the wide, annealed gate of the
  /// recovery registers (a narrow gate lets a street's ground and facades hold the scan where it
  /// was) and the recovery's correction bounds apply.
  Rejection track(const PointCloud& source, const registration::PreparedTarget& local_map,
                  const Isometry3d& T_guess, bool have_velocity, registration::MatchResult& match,
                  StageTimes& times, const Isometry3d* extra_start = nullptr);

  /// Median inlier ratio of the last accepted frames (0 before the first).
  double recentInlierRatio() const;
  /// Forgets the recent inlier ratios (the local map restarted).
  void forgetRecentInliers() { recent_inliers_.clear(); }
  /// The recent inlier ratios start again from `inlier_ratio` (the view after a gap overlaps the
  /// local map less than the frames before it did).
  void restartRecentInliers(double inlier_ratio) { recent_inliers_.assign(1, inlier_ratio); }

  /// The tracking ICP (its target options are the local map's).
  const registration::IcpMatcher& icp() const { return *icp_; }
  /// The same ICP with the correspondence gate annealed from TrackingParams::recovery_gate;
  /// null when recovery_gate is 0.
  const registration::IcpMatcher* wideGate() const { return wide_gate_.get(); }

 private:
  /// The wide-gate ICP from T_guess and from the starts of TrackingParams::start_search_range;
  /// the accepted match (under `bounds`) with the highest inlier ratio, else the best rejected.
  registration::MatchResult searchStart(const PointCloud& source,
                                        const registration::PreparedTarget& local_map,
                                        const Isometry3d& T_guess, const AcceptanceBounds& bounds,
                                        const Isometry3d* extra_start) const;

  TrackingParams params_;
  std::unique_ptr<registration::IcpMatcher> icp_;        // frame → local map
  std::unique_ptr<registration::IcpMatcher> wide_gate_;  // frame → local map, annealed wide gate
  std::deque<double> recent_inliers_;      // inlier ratios of the last tracked frames
};

}  // namespace obm::frontend
