#include "obm/frontend/motion_model.hpp"

namespace obm::frontend {

void ConstantVelocityModel::reset() {
  last_ = prev_ = Isometry3d::Identity();
  t_last_ = t_prev_ = 0.0;
  count_ = 0;
}

void ConstantVelocityModel::update(const Isometry3d& T_world_sensor, double t) {
  prev_ = last_;
  t_prev_ = t_last_;
  last_ = T_world_sensor;
  t_last_ = t;
  if (count_ < 2) ++count_;
}

Isometry3d ConstantVelocityModel::lastMotion() const {
  if (count_ < 2) return Isometry3d::Identity();
  return prev_.inverse() * last_;
}

double ConstantVelocityModel::steps(double t, bool use_time) const {
  if (count_ < 2 || !use_time) return 1.0;
  const double dt_prev = t_last_ - t_prev_;
  const double dt = t - t_last_;
  return dt_prev > 0.0 && dt > 0.0 ? dt / dt_prev : 1.0;
}

Isometry3d ConstantVelocityModel::predict(double t, bool use_time) const {
  if (count_ == 0) return Isometry3d::Identity();
  if (count_ == 1) return last_;
  const Isometry3d motion = lastMotion();
  const double s = steps(t, use_time);
  if (s == 1.0) return last_ * motion;
  // Constant twist: Exp(s · Log(motion)) (Log / Exp on SE(3), translation first).
  return last_ * expSE3(s * logSE3(motion));
}

void ConstantVelocityModel::applyCorrection(const Isometry3d& T_new_old) {
  last_ = T_new_old * last_;
  prev_ = T_new_old * prev_;
}

}  // namespace obm::frontend
