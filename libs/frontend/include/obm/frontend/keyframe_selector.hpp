#pragma once
/// \file keyframe_selector.hpp
/// The keyframe decision: a tracked frame becomes a keyframe when the sensor has travelled
/// `distance` or rotated `rotation` since the last keyframe, after `max_frames` frames, or when
/// its overlap with the local map drops (`overlap_drop`: the inlier ratio against the recent ones).
#include <cstddef>

#include "obm/core/se3.hpp"
#include "obm/frontend/params.hpp"

namespace obm::frontend {

class KeyframeSelector {
 public:
  explicit KeyframeSelector(const KeyframeParams& params = {});
  /// Whether the frame at `T_world_sensor` is a keyframe, given the last keyframe's pose and the
  /// number of frames since it (the last keyframe itself counts 0).
  bool isKeyframe(const Isometry3d& T_world_last_keyframe, const Isometry3d& T_world_sensor,
                  std::size_t frames_since_keyframe) const;
  /// The same, with the frame's inlier ratio against the local map and the recent frames' median
  /// (Tracker::recentInlierRatio before this frame; 0 when there is none yet).
  bool isKeyframe(const Isometry3d& T_world_last_keyframe, const Isometry3d& T_world_sensor,
                  std::size_t frames_since_keyframe, double inlier_ratio,
                  double recent_inlier_ratio) const;
  const KeyframeParams& params() const { return params_; }

 private:
  KeyframeParams params_;
};

}  // namespace obm::frontend
