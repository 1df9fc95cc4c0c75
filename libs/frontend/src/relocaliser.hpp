#pragma once
/// \file relocaliser.hpp
/// Relocalisation of a lost piece of the drive. After a local-map restart the keyframes from the
/// restart on are joined to the map only by a weak bridge edge: the estimate of where they are may
/// be tens of metres and degrees off, and the proximity search of the loop closer, which looks
/// around that estimate, never proposes the places driven before. The relocaliser looks for them
/// without the estimate: the newest keyframe's place descriptor against every keyframe of the map
/// (heading-invariant), the most similar verified by the scan matcher from the descriptor's yaw,
/// and the piece is moved onto the map once `confirmations` keyframes in a row agree on where it
/// is. Private to libs/frontend.
#include <cstddef>
#include <optional>
#include <utility>
#include <vector>

#include "loop_closer.hpp"
#include "obm/frontend/frontend.hpp"
#include "obm/frontend/params.hpp"

namespace obm::frontend {

class Relocaliser {
 public:
  /// `verifier` registers keyframes against submaps (it must outlive this object).
  Relocaliser(const RelocalisationParams& params, const LoopCloser& verifier);

  /// The local map restarted at keyframe `first`: from it on the keyframes form a piece that is
  /// not on the map. A piece still lost when the next one starts stays lost (its keyframes are
  /// no candidates: their poses are in no known relation to the map).
  void startPiece(std::size_t first);
  /// First keyframe of the piece being relocalised, if any.
  std::optional<std::size_t> pieceStart() const { return piece_start_; }

  /// What joins the piece to the map.
  struct Join {
    /// Moves the piece's poses onto the map: T_world_sensor ← T_map_piece · T_world_sensor.
    Isometry3d T_map_piece = Isometry3d::Identity();
    /// The agreeing verified loops (accepted, relocalisation = true) with their matches, whose
    /// edges join the piece to the map.
    std::vector<std::pair<LoopClosure, registration::MatchResult>> loops;
  };

  /// Tries the newest keyframe of the current piece: every verified candidate is appended to
  /// `loops` (rejected ones with their reason). Returns the join once confirmed; the piece is then
  /// on the map and the search stops until the next restart.
  std::optional<Join> search(const std::vector<Keyframe>& keyframes,
                             std::vector<LoopClosure>& loops, FrontendStats& stats,
                             StageTimes& times);

 private:
  /// A verified match of one keyframe of the piece and the correction it implies.
  struct Hypothesis {
    LoopClosure lc;
    registration::MatchResult match;
    Isometry3d T_map_piece;
  };
  /// Keyframes of the map (before the piece, not dropped, not in a lost piece) most similar to
  /// keyframe k, as (descriptor distance, keyframe, yaw of T_candidate_k), best first.
  struct Candidate {
    double distance;
    std::size_t id;
    double yaw;
  };
  std::vector<Candidate> candidates(const std::vector<Keyframe>& keyframes, std::size_t k) const;
  bool onMap(std::size_t id) const;
  bool agree(const Isometry3d& a, const Isometry3d& b) const;

  RelocalisationParams params_;
  const LoopCloser& verifier_;
  std::optional<std::size_t> piece_start_;
  std::vector<std::pair<std::size_t, std::size_t>> lost_;  ///< [first, last] of lost pieces
  std::vector<Hypothesis> recent_;  ///< accepted matches of the piece's latest keyframes
};

}  // namespace obm::frontend
