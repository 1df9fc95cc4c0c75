#pragma once
/// \file motion_model.hpp
/// Constant-velocity prediction of the next sensor pose: the last relative motion, applied once
/// more (scaled by the time between frames when time stamps are known).
#include "obm/core/se3.hpp"

namespace obm::frontend {

/// Keeps the last two accepted poses and predicts the next one.
class ConstantVelocityModel {
 public:
  /// Forgets the history (the next prediction is the last pose, or the identity).
  void reset();
  /// Records the pose of a frame at time `t` [s] (t <= previous t is treated as "unknown time").
  void update(const Isometry3d& T_world_sensor, double t);
  /// Predicted T_world_sensor at time `t`: T_last · Exp(s · Log(T_prev⁻¹ · T_last)) with
  /// s = (t − t_last)/(t_last − t_prev) when `use_time` and both intervals are positive, else
  /// s = 1 (one more step of the same motion). With fewer than two poses: the last pose (or I).
  Isometry3d predict(double t, bool use_time = true) const;
  /// How many steps of the last motion predict() applies for time `t` (the s above; 1 without
  /// time stamps or with fewer than two poses): over a gap in the stamps, the steps lost + 1.
  double steps(double t, bool use_time = true) const;
  /// The last recorded pose (identity before any).
  const Isometry3d& lastPose() const { return last_; }
  /// The last relative motion T_prev⁻¹ · T_last (identity with fewer than two poses).
  Isometry3d lastMotion() const;
  /// Number of poses recorded (saturates at 2).
  int count() const { return count_; }
  /// Translates the history by a rigid correction (after a pose-graph update moved the world):
  /// T ← T_new_old · T for both remembered poses.
  void applyCorrection(const Isometry3d& T_new_old);

 private:
  Isometry3d last_ = Isometry3d::Identity();
  Isometry3d prev_ = Isometry3d::Identity();
  double t_last_ = 0.0, t_prev_ = 0.0;
  int count_ = 0;
};

}  // namespace obm::frontend
