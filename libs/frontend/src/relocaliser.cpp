#include "relocaliser.hpp"

#include <algorithm>
#include <string>

#include "obm/frontend/stages.hpp"
#include "obm/core/log.hpp"
#include "obm/core/se3.hpp"
#include "obm/frontend/descriptor.hpp"

namespace obm::frontend {

namespace {
constexpr const char* kLog = "frontend";
}  // namespace

Relocaliser::Relocaliser(const RelocalisationParams& params, const LoopCloser& verifier)
    : params_(params), verifier_(verifier) {}

void Relocaliser::startPiece(std::size_t first) {
  if (piece_start_ && first > *piece_start_) lost_.emplace_back(*piece_start_, first - 1);
  piece_start_ = first;
  recent_.clear();
}

bool Relocaliser::onMap(std::size_t id) const {
  if (piece_start_ && id >= *piece_start_) return false;
  for (const auto& [first, last] : lost_)
    if (id >= first && id <= last) return false;
  return true;
}

bool Relocaliser::agree(const Isometry3d& a, const Isometry3d& b) const {
  const Isometry3d d = a.inverse() * b;
  return d.translation().norm() <= params_.agreement_translation &&
         rotationAngle(d.linear()) <= params_.agreement_rotation;
}

std::vector<Relocaliser::Candidate> Relocaliser::candidates(const std::vector<Keyframe>& keyframes,
                                                            std::size_t k) const {
  std::vector<Candidate> found;
  const Keyframe& cur = keyframes[k];
  if (cur.descriptor.empty()) return found;
  for (std::size_t j = 0; j < k; ++j) {
    const Keyframe& c = keyframes[j];
    if (c.dropped || c.descriptor.empty() || !onMap(j)) continue;
    // a = the current keyframe, b = the candidate: the yaw is that of T_candidate_current.
    const DescriptorMatch m = compareDescriptors(cur.descriptor, c.descriptor);
    if (m.distance <= params_.max_descriptor_distance) found.push_back({m.distance, j, m.yaw});
  }
  std::sort(found.begin(), found.end(),
            [](const Candidate& a, const Candidate& b) { return a.distance < b.distance; });
  return found;
}

std::optional<Relocaliser::Join> Relocaliser::search(const std::vector<Keyframe>& keyframes,
                                                     std::vector<LoopClosure>& loops,
                                                     FrontendStats& stats, StageTimes& times) {
  if (!params_.enabled || !piece_start_ || keyframes.empty()) return std::nullopt;
  const std::size_t k = keyframes.size() - 1;
  if (k < *piece_start_) return std::nullopt;

  std::vector<Candidate> found;
  {
    TimedStage s(times, Stage::Relocalise);
    found = candidates(keyframes, k);
  }
  // Matches of keyframes too far back no longer count as "in a row".
  const std::size_t window = 2 * params_.confirmations;
  recent_.erase(std::remove_if(recent_.begin(), recent_.end(),
                               [&](const Hypothesis& h) { return h.lc.to + window < k; }),
                recent_.end());

  std::vector<std::size_t> tried;
  for (const Candidate& c : found) {
    if (tried.size() >= params_.max_candidates) break;
    // Neighbours of a candidate already tried verify against nearly the same submap.
    if (nearTried(tried, c.id, verifier_.submapKeyframes())) continue;
    tried.push_back(c.id);

    LoopClosure lc;
    lc.from = c.id;
    lc.to = k;
    lc.relocalisation = true;
    lc.descriptor_distance = c.distance;
    ++stats.loop_candidates;
    // The estimate says nothing about where the piece is: the only guess is the descriptor's
    // heading, at the candidate's place.
    const Isometry3d T_init(Eigen::AngleAxisd(c.yaw, Eigen::Vector3d::UnitZ()));
    const registration::MatchResult r = verifier_.verifyFrom(lc, keyframes, T_init, times);
    if (const Rejection why = checkMatch(r, params_.min_quality, params_.min_inlier_ratio);
        why.rejected()) {
      lc.rejection = why.kind;
      lc.reason = "relocalisation: " + why.detail;
      ++stats.loops_rejected;
      OBM_LOG_DEBUG(kLog, "relocalisation " << lc.from << " -> " << lc.to << " rejected: "
                                            << lc.reason << " (descriptor " << c.distance << ")");
      loops.push_back(lc);
      continue;
    }

    Hypothesis h{lc, r,
                 keyframes[c.id].T_world_sensor * r.T_target_source *
                     keyframes[k].T_world_sensor.inverse()};
    // The other keyframes of the piece that put it at the same place.
    std::vector<const Hypothesis*> agreeing;
    for (const Hypothesis& o : recent_) {
      // Another keyframe of the piece, matched onto another keyframe of the map (two keyframes
      // matched onto one place are one piece of evidence), at the same place.
      if (o.lc.to == k || o.lc.from == h.lc.from || !agree(o.T_map_piece, h.T_map_piece)) continue;
      const bool same_keyframe = std::any_of(agreeing.begin(), agreeing.end(),
                                             [&](const Hypothesis* a) { return a->lc.to == o.lc.to; });
      if (!same_keyframe) agreeing.push_back(&o);
    }
    if (agreeing.size() + 1 < params_.confirmations) {
      // Logged now; flipped to accepted if the next keyframes confirm it.
      h.lc.rejection = RejectionKind::NotConfirmed;
      h.lc.reason = "relocalisation: not confirmed by the next keyframes";
      OBM_LOG_DEBUG(kLog, "relocalisation " << lc.from << " -> " << lc.to << " (descriptor "
                                            << c.distance << ", quality " << r.quality
                                            << "): awaiting confirmation");
      loops.push_back(h.lc);
      recent_.push_back(std::move(h));
      continue;
    }

    Join join;
    join.T_map_piece = h.T_map_piece;
    for (const Hypothesis* o : agreeing) {
      LoopClosure confirmed = o->lc;
      confirmed.accepted = true;
      confirmed.rejection = RejectionKind::None;
      confirmed.reason.clear();
      for (LoopClosure& logged : loops)
        if (logged.relocalisation && logged.from == confirmed.from && logged.to == confirmed.to)
          logged = confirmed;
      join.loops.emplace_back(confirmed, o->match);
      ++stats.loops_accepted;
    }
    h.lc.accepted = true;
    h.lc.rejection = RejectionKind::None;
    h.lc.reason.clear();
    loops.push_back(h.lc);
    join.loops.emplace_back(h.lc, h.match);
    ++stats.loops_accepted;
    ++stats.relocalisations;
    OBM_LOG_INFO(kLog, "relocalised the keyframes since " << *piece_start_ << " at keyframe " << k
                                                          << " (onto keyframe " << lc.from
                                                          << ", moved "
                                                          << join.T_map_piece.translation().norm()
                                                          << " m, "
                                                          << rotationAngle(join.T_map_piece.linear()) *
                                                                 kRadToDeg
                                                          << " deg)");
    piece_start_.reset();
    recent_.clear();
    return join;
  }
  return std::nullopt;
}

}  // namespace obm::frontend
