#include "loop_closer.hpp"

#include <algorithm>
#include <cmath>

#include "obm/frontend/stages.hpp"
#include "obm/core/log.hpp"
#include "obm/core/se3.hpp"
#include "edge_information.hpp"
#include "local_map.hpp"

namespace obm::frontend {

namespace {
constexpr const char* kLog = "frontend";
}  // namespace

backend::Edge3 loopEdge(const LoopClosureParams& params, const LoopClosure& lc,
                        const registration::MatchResult& match) {
  backend::Edge3 e;
  e.from = static_cast<backend::NodeId>(lc.from);
  e.to = static_cast<backend::NodeId>(lc.to);
  e.T_from_to = backend::Pose3::fromIsometry(match.T_target_source);
  e.information = loopEdgeInformation(params, match);
  e.loss = params.loss;
  e.is_loop = true;
  return e;
}

Rejection checkMatch(const registration::MatchResult& r, double min_quality,
                     double min_inlier_ratio) {
  using K = RejectionKind;
  if (r.status != registration::MatchStatus::Ok &&
      r.status != registration::MatchStatus::NotConverged)
    return {K::MatchStatus, std::string("match status ") + toString(r.status)};
  if (!r.T_target_source.matrix().allFinite()) return {K::NonFinitePose, "non-finite pose"};
  if (r.quality < min_quality) return {K::Quality, "quality " + std::to_string(r.quality)};
  if (r.inlier_ratio < min_inlier_ratio)
    return {K::InlierRatio, "inlier ratio " + std::to_string(r.inlier_ratio)};
  return Rejection::accepted();
}

bool nearTried(const std::vector<std::size_t>& tried, std::size_t j, long window) {
  return std::any_of(tried.begin(), tried.end(), [&](std::size_t t) {
    return static_cast<long>(std::max(t, j) - std::min(t, j)) <= window;
  });
}

LoopCloser::LoopCloser(const LoopClosureParams& params, double submap_voxel,
                       const registration::ScanMatcher& matcher)
    : params_(params), submap_voxel_(submap_voxel), matcher_(matcher) {}

std::size_t LoopCloser::search(const std::vector<Keyframe>& keyframes,
                               std::vector<LoopClosure>& loops, backend::Optimizer& optimizer,
                               FrontendStats& stats, StageTimes& times) {
  const LoopClosureParams& lp = params_;
  const std::size_t k = keyframes.size() - 1;
  if (!lp.enabled || k == 0 || k < next_search_) return 0;
  next_search_ = k + lp.check_every;
  ++stats.loop_searches;

  const std::vector<std::pair<double, std::size_t>> found = candidates(keyframes, k, times);
  std::vector<std::size_t> tried;
  std::size_t accepted = 0;
  for (const auto& [d, j] : found) {
    if (tried.size() >= lp.max_candidates) break;
    // Candidates next to one already tried would verify against nearly the same submap.
    if (nearTried(tried, j, lp.submap_keyframes)) continue;
    tried.push_back(j);
    LoopClosure lc;
    lc.from = j;
    lc.to = k;
    if (lp.use_descriptor) {
      TimedStage s(times, Stage::LoopSearch);
      lc.descriptor_distance =
          compareDescriptors(keyframes[k].descriptor, keyframes[j].descriptor).distance;
    }
    if (lp.use_descriptor && lc.descriptor_distance > lp.max_descriptor_distance) {
      lc.rejection = RejectionKind::DescriptorDistance;
      lc.reason = "descriptor distance " + std::to_string(lc.descriptor_distance);
      loops.push_back(lc);
      continue;
    }
    ++stats.loop_candidates;
    const registration::MatchResult r = verify(lc, keyframes, times);
    const Rejection why = check(lc, r, keyframes);
    lc.rejection = why.kind;
    lc.reason = why.detail;
    lc.accepted = !why.rejected();
    if (!lc.accepted) {
      ++stats.loops_rejected;
      OBM_LOG_DEBUG(kLog, "loop " << lc.from << " -> " << lc.to << " rejected: " << lc.reason);
      loops.push_back(lc);
      continue;
    }
    ++stats.loops_accepted;
    OBM_LOG_INFO(kLog, "loop closure keyframe " << lc.to << " -> " << lc.from << " (" << d
                                                << " m apart, correction " << lc.correction
                                                << " m, quality " << r.quality << ", inliers "
                                                << r.inlier_ratio << ")");
    {
      TimedStage s(times, Stage::Graph);
      optimizer.addEdge(loopEdge(lp, lc, r));
    }
    loops.push_back(lc);
    ++accepted;
    break;
  }
  if (accepted > 0) next_search_ = k + std::max(lp.check_every, lp.cooldown);
  return accepted;
}

std::vector<std::pair<double, std::size_t>> LoopCloser::candidates(
    const std::vector<Keyframe>& keyframes, std::size_t k, StageTimes& times) const {
  const LoopClosureParams& lp = params_;
  std::vector<std::pair<double, std::size_t>> found;
  TimedStage s(times, Stage::LoopSearch);
  const Keyframe& cur = keyframes[k];
  const Eigen::Vector3d z_cur = cur.T_world_sensor.linear().col(2);  // optical axis
  const double min_view_cos = std::cos(lp.max_view_angle);
  for (std::size_t j = 0; j < k; ++j) {
    const Keyframe& c = keyframes[j];
    if (c.dropped) continue;  // an older keyframe stores the place
    const double along = cur.travelled - c.travelled;
    if (along < lp.min_travel) continue;
    const double radius =
        std::min(lp.max_search_radius, lp.search_radius + lp.search_radius_per_m * along);
    const double d = (cur.T_world_sensor.translation() - c.T_world_sensor.translation()).norm();
    if (d > radius) continue;
    if (lp.max_view_angle > 0.0 && z_cur.dot(c.T_world_sensor.linear().col(2)) < min_view_cos)
      continue;
    found.emplace_back(d, j);
  }
  std::sort(found.begin(), found.end());
  return found;
}

registration::MatchResult LoopCloser::verify(LoopClosure& lc,
                                             const std::vector<Keyframe>& keyframes,
                                             StageTimes& times) const {
  const Isometry3d T_init =
      keyframes[lc.from].T_world_sensor.inverse() * keyframes[lc.to].T_world_sensor;
  return verifyFrom(lc, keyframes, T_init, times);
}

registration::MatchResult LoopCloser::verifyFrom(LoopClosure& lc,
                                                 const std::vector<Keyframe>& keyframes,
                                                 const Isometry3d& T_init,
                                                 StageTimes& times) const {
  const LoopClosureParams& lp = params_;
  const Keyframe& cur = keyframes[lc.to];
  const Keyframe& cand = keyframes[lc.from];
  registration::MatchResult r;
  {
    TimedStage s(times, verifyStage());
    // Target: the candidate and its neighbours, in the candidate's frame.
    const long w = lp.submap_keyframes;
    const long lo = std::max<long>(0, static_cast<long>(lc.from) - w);
    const long hi = std::min<long>(static_cast<long>(lc.to) - 1, static_cast<long>(lc.from) + w);
    std::vector<std::size_t> members;
    for (long i = lo; i <= hi; ++i) {
      const std::size_t j = static_cast<std::size_t>(i);
      if (cur.travelled - keyframes[j].travelled >= 0.5 * lp.min_travel)  // not the recent past
        members.push_back(j);
    }
    const PointCloud submap = mergeKeyframeClouds(keyframes, members,
                                                  cand.T_world_sensor.inverse(), submap_voxel_);
    const registration::PreparedTarget target = matcher_.prepare(submap);
    r = matcher_.match(cur.cloud, target, T_init);
  }
  lc.T_from_to = r.T_target_source;
  lc.quality = r.quality;
  lc.inlier_ratio = r.inlier_ratio;
  lc.start = r.start;
  const Isometry3d correction = T_init.inverse() * r.T_target_source;
  lc.correction = correction.translation().norm();
  lc.correction_rotation = rotationAngle(correction.linear());
  return r;
}

Rejection LoopCloser::check(const LoopClosure& lc, const registration::MatchResult& r,
                            const std::vector<Keyframe>& keyframes) const {
  const LoopClosureParams& lp = params_;
  const double travelled = keyframes[lc.to].travelled - keyframes[lc.from].travelled;
  const double max_corr =
      lp.max_correction > 0.0
          ? lp.max_correction
          : std::min(lp.max_search_radius, lp.search_radius + lp.search_radius_per_m * travelled);
  if (Rejection why = checkMatch(r, lp.min_quality, lp.min_inlier_ratio); why.rejected())
    return why;
  if (lc.correction > max_corr)
    return {RejectionKind::LoopCorrection, "correction " + std::to_string(lc.correction) + " m"};
  if (lp.max_correction_rotation > 0.0) {
    const double max_rot = lp.max_correction_rotation + lp.correction_rotation_per_m * travelled;
    if (lc.correction_rotation > max_rot)
      return {RejectionKind::LoopRotationCorrection,
              "rotation correction " + std::to_string(lc.correction_rotation * kRadToDeg) +
                  " deg (at most " + std::to_string(max_rot * kRadToDeg) + ")"};
  }
  return Rejection::accepted();
}

}  // namespace obm::frontend
