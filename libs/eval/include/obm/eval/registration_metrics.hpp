#pragma once
/// \file registration_metrics.hpp
/// Pairwise registration errors as the RIENet / DCP / RPM-Net evaluation computes them, plus the
/// registration recall of the 3DMatch / KITTI protocols. Definitions with equations:
/// docs/metrics.md.
#include <cstddef>
#include <vector>

#include "obm/core/se3.hpp"

namespace obm::eval {

/// Errors of one estimated transform against its ground truth (both `T_target_source`).
struct PairErrors {
  /// |euler_zyx(R_pred) − euler_zyx(R_gt)| per angle (z, y, x) [deg]. Plain difference without
  /// wrapping, as RIENet/DCP compute it (scipy `as_euler('zyx')` on both matrices).
  Eigen::Vector3d euler_abs_deg = Eigen::Vector3d::Zero();
  /// |t_pred − t_gt| per component [translation units].
  Eigen::Vector3d t_abs = Eigen::Vector3d::Zero();
  /// Isotropic rotation error arccos(clip((tr(R_gtᵀ R_pred) − 1) / 2, −1, 1)) [deg] (RRE).
  double rre_deg = 0.0;
  /// Isotropic translation error ‖t_pred − t_gt‖ [translation units] (RTE).
  double rte = 0.0;
};

/// Computes the per-pair errors of `T_pred` against `T_gt`.
PairErrors pairErrors(const Isometry3d& T_pred, const Isometry3d& T_gt);

/// Success thresholds of registration recall: a pair succeeds when RRE < max_rre_deg and
/// RTE < max_rte (strict, as FCGF / D3Feat / PointDSC evaluate KITTI).
struct RecallThresholds {
  double max_rre_deg = 5.0;  ///< [deg]
  double max_rte = 2.0;      ///< [translation units, m for KITTI]
  /// The KITTI LiDAR registration protocol: 5° and 2 m.
  static RecallThresholds kitti() { return {5.0, 2.0}; }
  /// Whether a pair with these errors counts as registered (both strictly below the thresholds).
  bool accepts(double rre_deg, double rte) const { return rre_deg < max_rre_deg && rte < max_rte; }
};

/// Aggregated registration errors over all pairs added to a RegistrationAccumulator.
/// With n == 0 every value is NaN.
struct RegistrationSummary {
  std::size_t n = 0;    ///< number of pairs
  double mae_r = 0.0;   ///< MAE(R): mean over pairs and the 3 zyx Euler angles of |Δ| [deg]
  double mae_t = 0.0;   ///< MAE(t): mean over pairs and the 3 components of |Δt| [units]
  double rmse_r = 0.0;  ///< RMSE(R): sqrt of the mean over pairs and angles of Δ² [deg]
  double rmse_t = 0.0;  ///< RMSE(t): sqrt of the mean over pairs and components of Δt² [units]
  double mie_r = 0.0;   ///< MIE(R): mean isotropic rotation error (mean RRE) [deg]
  double mie_t = 0.0;   ///< MIE(t): mean isotropic translation error (mean RTE) [units]
  double rmse_rre_deg = 0.0;     ///< sqrt(mean RRE²), RIENet's `deg_rmse` [deg]
  double rmse_rte = 0.0;         ///< sqrt(mean RTE²), RIENet's `trans_rmse` [units]
  double median_rre_deg = 0.0;   ///< median RRE [deg]
  double median_rte = 0.0;       ///< median RTE [units]
  double recall = 0.0;           ///< fraction of pairs with RRE < max_rre_deg and RTE < max_rte
  double rre_success_deg = 0.0;  ///< mean RRE over successful pairs only [deg] (NaN if none)
  double rte_success = 0.0;      ///< mean RTE over successful pairs only [units] (NaN if none)
  double mean_ms = 0.0;          ///< mean runtime per pair [ms]
  double median_ms = 0.0;        ///< median runtime per pair [ms]
};

/// Collects per-pair errors and runtimes and summarises them (RIENet Table metrics + recall).
class RegistrationAccumulator {
 public:
  explicit RegistrationAccumulator(RecallThresholds thresholds = RecallThresholds{})
      : thresholds_(thresholds) {}

  /// Adds one pair; `runtime_ms` is the wall time the registration took [ms]. Returns its errors.
  const PairErrors& add(const Isometry3d& T_pred, const Isometry3d& T_gt, double runtime_ms = 0.0);

  /// Aggregates everything added so far.
  RegistrationSummary summary() const;

  /// Per-pair errors in the order added.
  const std::vector<PairErrors>& pairs() const { return pairs_; }
  /// Per-pair runtimes [ms] in the order added.
  const std::vector<double>& runtimesMs() const { return runtimes_ms_; }
  const RecallThresholds& thresholds() const { return thresholds_; }
  std::size_t size() const { return pairs_.size(); }
  void clear();

 private:
  RecallThresholds thresholds_;
  std::vector<PairErrors> pairs_;
  std::vector<double> runtimes_ms_;
};

}  // namespace obm::eval
