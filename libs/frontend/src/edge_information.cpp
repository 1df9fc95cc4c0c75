#include "edge_information.hpp"

#include <Eigen/Eigenvalues>

namespace obm::frontend {

Matrix6d edgeInformation(const Matrix6d& omega_theta, double scale, double sigma_t,
                         double sigma_r) {
  Matrix6d O = scale * 0.5 * (omega_theta + omega_theta.transpose());
  if (!O.allFinite()) O.setZero();
  Vector6d floor_var;
  floor_var << sigma_t * sigma_t, sigma_t * sigma_t, sigma_t * sigma_t, sigma_r * sigma_r,
      sigma_r * sigma_r, sigma_r * sigma_r;
  const Matrix6d S = floor_var.asDiagonal();
  Matrix6d F = O * (Matrix6d::Identity() + S * O).inverse();
  F = 0.5 * (F + F.transpose());
  if (!F.allFinite()) F = O;
  Eigen::SelfAdjointEigenSolver<Matrix6d> es(F);
  Vector6d ev = es.eigenvalues().cwiseMax(1.0);
  F = es.eigenvectors() * ev.asDiagonal() * es.eigenvectors().transpose();
  F = 0.5 * (F + F.transpose());
  return registration::informationThetaToG2o(F);
}

Matrix6d bridgeInformation(double sigma_t, double sigma_r) {
  Vector6d d;
  const double it = 1.0 / (sigma_t * sigma_t), ir = 1.0 / (sigma_r * sigma_r);
  d << it, it, it, ir, ir, ir;
  return registration::informationThetaToG2o(Matrix6d(d.asDiagonal()));
}

Matrix6d odometryEdgeInformation(const TrackingParams& params,
                                 const registration::MatchResult* match, bool bridged) {
  if (bridged || match == nullptr)
    return bridgeInformation(params.bridge_sigma_translation, params.bridge_sigma_rotation);
  return edgeInformation(match->information, params.information_scale,
                         params.floor_sigma_translation, params.floor_sigma_rotation);
}

Matrix6d loopEdgeInformation(const LoopClosureParams& params,
                             const registration::MatchResult& match) {
  return edgeInformation(match.information, params.information_scale,
                         params.floor_sigma_translation, params.floor_sigma_rotation);
}

}  // namespace obm::frontend
