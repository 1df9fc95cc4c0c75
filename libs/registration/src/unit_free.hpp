#pragma once
// The unit-free form of ICP's normal equations, shared by the conditioning score (confidence.cpp)
// and the weak-direction hold (icp.cpp), so that one threshold means the same in both.
#include "obm/core/se3.hpp"

namespace obm::registration::detail {

/// Scaling δ = D·u of the pose step that makes rotation and translation commensurable:
/// D = diag(1, 1, 1, 1/L, 1/L, 1/L) with L the RMS lever arm of the paired points (identity
/// when L is 0).
inline Vector6d unitFreeScaling(double lever_arm) {
  Vector6d D = Vector6d::Ones();
  if (lever_arm > 0.0) D.tail<3>().setConstant(1.0 / lever_arm);
  return D;
}

/// D·H·D / weight: the Hessian in the scaled step, per unit of correspondence weight.
inline Matrix6d unitFreeHessian(const Matrix6d& H, const Vector6d& D, double weight) {
  return D.asDiagonal() * H * D.asDiagonal() / weight;
}

}  // namespace obm::registration::detail
