#pragma once
/// \file recovery.hpp
/// What happens when the tracking match of a frame is rejected: an ordered list of named steps,
/// each of which may take the frame (status Recovered, with its own registration); when none
/// does, the frame is bridged with the constant-velocity guess. Private to libs/frontend.
///
///  1. wide_gate       ICP against the local map with the correspondence gate annealed from
///                     TrackingParams::recovery_gate, from the guess and the guess turned by
///                     ±k·recovery_rotation_step; the best acceptable registration is taken.
///  1b. gap_paths     after a gap in the time stamps: the wide-gate ICP from the poses of the
///                     paths the car may have driven meanwhile (the turn continued for part of
///                     the gap, the speed changed), judged against one another.
///  2. last_keyframe   the scan matcher (OBMNet + ICP or ICP) against the last keyframe alone.
///  3. second_opinion  a wide-gate registration that failed only the relative inlier ratio is
///                     taken when the last-keyframe registration lands on the same pose.
///  4. confirmed_jump  a last-keyframe registration beyond the correction bounds (a sudden jump)
///                     is taken when the previous sweep's registration predicts it.
///
/// Every step appends to the frame's reason what it found, so frames.csv and the log say why a
/// frame was recovered or bridged.
#include <cstddef>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "obm/core/point_cloud.hpp"
#include "obm/core/se3.hpp"
#include "obm/core/timer.hpp"
#include "obm/frontend/frontend.hpp"
#include "obm/frontend/params.hpp"
#include "obm/registration/icp.hpp"
#include "obm/registration/prepared_target.hpp"
#include "obm/registration/scan_matcher.hpp"

namespace obm::frontend {

/// A registration of the scan matcher against the last keyframe that may be a sudden jump,
/// waiting for the next sweep to confirm it (TrackingParams::recovery_confirm_jumps).
struct JumpCandidate {
  std::size_t frame = 0;      ///< its frame index
  std::size_t keyframes = 0;  ///< the number of keyframes then (a new keyframe voids it)
  Isometry3d T_guess = Isometry3d::Identity();         ///< its constant-velocity guess
  Isometry3d T_world_sensor = Isometry3d::Identity();  ///< its registered pose
};

/// The frame being recovered and what the recovery may use.
struct RecoveryInput {
  const PointCloud& source;         ///< the preprocessed sweep
  const Isometry3d& T_guess;        ///< its constant-velocity guess
  const registration::PreparedTarget& local_map;  ///< the map tracking registered against
  const Keyframe& last_keyframe;
  std::size_t keyframes = 0;               ///< number of keyframes
  Isometry3d last_motion;                  ///< the motion model's last relative motion
  double inlier_reference = 0.0;           ///< median inlier ratio of the recent tracked frames
  /// [rad] how much more the guess turns from the last pose than the last motion did: the turn
  /// the motion model extrapolated over a gap in the time stamps (0 without a gap). A guess
  /// extrapolated by X may be wrong by X (the car may have stopped turning when the sweeps
  /// stopped coming), so the recovery's rotation bound and hypotheses grow by it.
  double extrapolated_rotation = 0.0;
  /// The pose of the frame before and the steps of the last motion the guess extrapolated from
  /// it (1 without a gap in the time stamps; the gap_paths step runs from it over a gap).
  Isometry3d T_last = Isometry3d::Identity();
  double steps = 1.0;
  /// The frame before was bridged: its pose is a guess, and no path starts from it.
  bool last_bridged = false;
  /// Every keyframe so far (world poses); those before `old_keyframes_end` are not in the local
  /// map. The gap_paths step registers against them too (TrackingParams::recovery_gap_map_radius),
  /// merged at `map_voxel`. Null: the local map only.
  const std::vector<Keyframe>* all_keyframes = nullptr;
  std::size_t old_keyframes_end = 0;
  double map_voxel = 0.0;
};

class Recovery {
 public:
  /// `wide_gate`: the tracker's wide-gate ICP (null: no wide_gate step); `matcher`: the scan
  /// matcher of the last_keyframe step. Both must outlive this object.
  Recovery(const TrackingParams& params, const registration::IcpMatcher* wide_gate,
           const registration::ScanMatcher& matcher);

  /// Before every registered sweep: the candidate of the sweep before moves to "previous" (only
  /// the next sweep may confirm it).
  void startSweep();

  /// Runs the steps in order after tracking rejected `fr.match` (`rejection`, which becomes
  /// fr.rejection). A step that takes the frame sets fr.match (world frame), fr.status =
  /// Recovered and fr.reason; otherwise fr.status = Bridged and fr.reason says what every step
  /// found (fr.match is left as tracking's).
  void recover(const RecoveryInput& in, const Rejection& rejection, FrameResult& fr,
               StageTimes& times);

  /// A jump confirmed by this sweep: the previous sweep's candidate (which the caller moves to
  /// its registered pose), once; empty otherwise.
  std::optional<JumpCandidate> takeConfirmedJump();

  /// The name of the step that took the last recovered frame (empty when it was bridged).
  const std::string& takenBy() const { return taken_by_; }

  /// The earlier map (world frame) the gap_paths step registered the last recovered frame
  /// against, once; null when it was the local map (TrackingParams::recovery_gap_map_radius).
  std::unique_ptr<registration::PreparedTarget> takeRecoveryMap() {
    return std::move(recovery_map_);
  }

  /// A new keyframe: the cached last-keyframe target is stale.
  void keyframeAdded() { last_keyframe_target_.reset(); }

  /// The step names, in order.
  static std::vector<std::string> stepNames();

 private:
  struct Attempt;
  using StepFn = bool (Recovery::*)(Attempt&);
  struct Step {
    const char* name;
    StepFn run;  ///< true when the step took the frame
  };
  static const Step kSteps[];

  bool wideGate(Attempt& a);
  bool gapPaths(Attempt& a);
  bool lastKeyframe(Attempt& a);
  bool secondOpinion(Attempt& a);
  bool confirmedJump(Attempt& a);

  bool agree(const Isometry3d& T_a, const Isometry3d& T_b) const;

  TrackingParams params_;
  const registration::IcpMatcher* wide_gate_;
  const registration::ScanMatcher& matcher_;
  std::unique_ptr<registration::PreparedTarget>
      last_keyframe_target_;                // lazily, for the last_keyframe step
  std::optional<JumpCandidate> candidate_;  // from this sweep, if any
  std::optional<JumpCandidate> previous_;   // from the sweep before, if any
  std::optional<JumpCandidate> confirmed_;  // set by recover(), taken by the caller
  std::unique_ptr<registration::PreparedTarget> recovery_map_;  // see takeRecoveryMap()
  std::string taken_by_;                    // the step that took the last frame
};

}  // namespace obm::frontend
