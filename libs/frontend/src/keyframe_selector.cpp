#include "obm/frontend/keyframe_selector.hpp"

namespace obm::frontend {

KeyframeSelector::KeyframeSelector(const KeyframeParams& params) : params_(params) {
  params_.validate();
}

bool KeyframeSelector::isKeyframe(const Isometry3d& T_world_last_keyframe,
                                  const Isometry3d& T_world_sensor,
                                  std::size_t frames_since_keyframe) const {
  if (params_.max_frames > 0 && frames_since_keyframe >= params_.max_frames) return true;
  const Isometry3d delta = T_world_last_keyframe.inverse() * T_world_sensor;
  return delta.translation().norm() >= params_.distance ||
         rotationAngle(delta.linear()) >= params_.rotation;
}

bool KeyframeSelector::isKeyframe(const Isometry3d& T_world_last_keyframe,
                                  const Isometry3d& T_world_sensor,
                                  std::size_t frames_since_keyframe, double inlier_ratio,
                                  double recent_inlier_ratio) const {
  if (isKeyframe(T_world_last_keyframe, T_world_sensor, frames_since_keyframe)) return true;
  return params_.overlap_drop > 0.0 && recent_inlier_ratio > 0.0 &&
         frames_since_keyframe >= params_.overlap_min_frames &&
         inlier_ratio < params_.overlap_drop * recent_inlier_ratio;
}

}  // namespace obm::frontend
