#include "obm/eval/registration_metrics.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

#include "obm/eval/statistics.hpp"

namespace obm::eval {

PairErrors pairErrors(const Isometry3d& T_pred, const Isometry3d& T_gt) {
  const Eigen::Matrix3d R_pred = T_pred.linear();
  const Eigen::Matrix3d R_gt = T_gt.linear();
  PairErrors e;
  // RIENet / DCP: both rotations go through scipy's as_euler('zyx', degrees=True) and the angles
  // are subtracted without wrapping.
  e.euler_abs_deg = ((eulerZYX(R_pred) - eulerZYX(R_gt)) * kRadToDeg).cwiseAbs();
  e.t_abs = (T_pred.translation() - T_gt.translation()).cwiseAbs();
  // RPM-Net / RIENet isotropic error: arccos of the clipped cosine of the residual rotation
  // R_gtᵀ·R_pred; the arccos form is kept (not atan2) so the numbers match the reference code.
  const double c = std::clamp(0.5 * ((R_gt.transpose() * R_pred).trace() - 1.0), -1.0, 1.0);
  e.rre_deg = std::acos(c) * kRadToDeg;
  e.rte = (T_pred.translation() - T_gt.translation()).norm();
  return e;
}

const PairErrors& RegistrationAccumulator::add(const Isometry3d& T_pred, const Isometry3d& T_gt,
                                               double runtime_ms) {
  pairs_.push_back(pairErrors(T_pred, T_gt));
  runtimes_ms_.push_back(runtime_ms);
  return pairs_.back();
}

void RegistrationAccumulator::clear() {
  pairs_.clear();
  runtimes_ms_.clear();
}

RegistrationSummary RegistrationAccumulator::summary() const {
  RegistrationSummary s;
  s.n = pairs_.size();
  std::vector<double> euler, trans, rre, rte, rre_ok, rte_ok;
  euler.reserve(3 * s.n);
  trans.reserve(3 * s.n);
  for (const PairErrors& p : pairs_) {
    for (int k = 0; k < 3; ++k) {
      euler.push_back(p.euler_abs_deg[k]);
      trans.push_back(p.t_abs[k]);
    }
    rre.push_back(p.rre_deg);
    rte.push_back(p.rte);
    if (thresholds_.accepts(p.rre_deg, p.rte)) {
      rre_ok.push_back(p.rre_deg);
      rte_ok.push_back(p.rte);
    }
  }
  s.mae_r = mean(euler);
  s.mae_t = mean(trans);
  s.rmse_r = rootMeanSquare(euler);
  s.rmse_t = rootMeanSquare(trans);
  s.mie_r = mean(rre);
  s.mie_t = mean(rte);
  s.rmse_rre_deg = rootMeanSquare(rre);
  s.rmse_rte = rootMeanSquare(rte);
  s.median_rre_deg = median(rre);
  s.median_rte = median(rte);
  s.recall = s.n == 0 ? std::numeric_limits<double>::quiet_NaN()
                      : static_cast<double>(rre_ok.size()) / static_cast<double>(s.n);
  s.rre_success_deg = mean(rre_ok);
  s.rte_success = mean(rte_ok);
  s.mean_ms = mean(runtimes_ms_);
  s.median_ms = median(runtimes_ms_);
  return s;
}

}  // namespace obm::eval
