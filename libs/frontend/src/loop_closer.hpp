#pragma once
/// \file loop_closer.hpp
/// Loop closure for the newest keyframe: candidate search (earlier keyframes within a radius that
/// grows with the distance travelled since them, nearest first), place-descriptor check,
/// verification by the scan matcher against the candidate's submap, acceptance tests, and the
/// robust loop edge added to the pose graph. Private to libs/frontend.
#include <cstddef>
#include <string>
#include <utility>
#include <vector>

#include "matcher_stage.hpp"
#include "obm/backend/optimizer.hpp"
#include "obm/core/timer.hpp"
#include "obm/frontend/frontend.hpp"
#include "obm/frontend/params.hpp"
#include "obm/registration/scan_matcher.hpp"

namespace obm::frontend {

/// The pose-graph edge of an accepted loop: lc.from → lc.to with the match's pose, its information
/// (loopEdgeInformation) and the robust loss of loop edges.
backend::Edge3 loopEdge(const LoopClosureParams& params, const LoopClosure& lc,
                        const registration::MatchResult& match);

/// The tests every verified loop match passes first, in order: a usable status, a finite pose,
/// quality and inlier ratio at least these. The first it fails (none when it passes).
Rejection checkMatch(const registration::MatchResult& match, double min_quality,
                     double min_inlier_ratio);

/// True when keyframe `j` is within `window` keyframes of one already `tried` (it would verify
/// against nearly the same submap).
bool nearTried(const std::vector<std::size_t>& tried, std::size_t j, long window);

class LoopCloser {
 public:
  /// `submap_voxel`: voxel grid of the candidate's submap (LocalMapParams::voxel); `matcher`
  /// verifies the candidates and must outlive this object.
  LoopCloser(const LoopClosureParams& params, double submap_voxel,
             const registration::ScanMatcher& matcher);

  /// Searches loop closures for the newest keyframe (every check_every keyframes, after an
  /// accepted loop every cooldown): each candidate tried is appended to `loops`, an accepted one
  /// adds a loop edge to `optimizer` and ends the search. Returns how many were accepted (the
  /// caller then optimises the graph).
  std::size_t search(const std::vector<Keyframe>& keyframes, std::vector<LoopClosure>& loops,
                     backend::Optimizer& optimizer, FrontendStats& stats, StageTimes& times);

  /// Keyframes on each side of a candidate in its submap (LoopClosureParams::submap_keyframes).
  int submapKeyframes() const { return params_.submap_keyframes; }

  /// The timing stage of the verification (matcherStage: "obmnet" or "loop_icp").
  Stage verifyStage() const { return matcherStage(matcher_); }

  /// Registers keyframe lc.to against the submap of keyframe lc.from (it and submap_keyframes
  /// neighbours, but not the recent past) from `T_init` (= T_from_to's guess); fills the pose,
  /// quality and inlier ratio of `lc`, and its correction of `T_init`.
  registration::MatchResult verifyFrom(LoopClosure& lc, const std::vector<Keyframe>& keyframes,
                                       const Isometry3d& T_init, StageTimes& times) const;

 private:
  /// Earlier keyframes at least min_travel behind keyframe `k` along the path and within
  /// min(max_search_radius, search_radius + search_radius_per_m · travelled) of it, as
  /// (distance, keyframe), nearest first (stage "loop_search").
  std::vector<std::pair<double, std::size_t>> candidates(const std::vector<Keyframe>& keyframes,
                                                         std::size_t k, StageTimes& times) const;
  /// verifyFrom the current estimate of the relative pose.
  registration::MatchResult verify(LoopClosure& lc, const std::vector<Keyframe>& keyframes,
                                   StageTimes& times) const;
  /// The test the verified match fails as a loop closure (none when it is one).
  Rejection check(const LoopClosure& lc, const registration::MatchResult& r,
                  const std::vector<Keyframe>& keyframes) const;

  LoopClosureParams params_;
  double submap_voxel_;
  const registration::ScanMatcher& matcher_;
  std::size_t next_search_ = 0;  // keyframe id of the next loop search
};

}  // namespace obm::frontend
