#pragma once
/// \file trajectory_metrics.hpp
/// Absolute trajectory error (ATE) after Umeyama alignment and relative pose error (RPE), as the
/// TUM RGB-D benchmark tools and evo define them. The trajectories must already be associated:
/// equal length, pose i of the estimate belongs to pose i of the ground truth.
/// Definitions with equations: docs/metrics.md.
#include <cstddef>
#include <utility>
#include <vector>

#include "obm/core/se3.hpp"
#include "obm/eval/kitti_odometry.hpp"  // PoseList

namespace obm::eval {

/// A similarity transform x ↦ s·R·x + t (s = 1 for a rigid SE(3) alignment).
struct Similarity3 {
  Eigen::Matrix3d R = Eigen::Matrix3d::Identity();
  Eigen::Vector3d t = Eigen::Vector3d::Zero();
  double s = 1.0;
  Eigen::Vector3d operator*(const Eigen::Vector3d& x) const { return s * (R * x) + t; }
  /// Applies the transform to a pose: rotation R·R_p, position s·R·t_p + t.
  Isometry3d operator*(const Isometry3d& T) const;
};

/// Least-squares (s, R, t) minimising Σ‖dst_i − (s·R·src_i + t)‖² (Umeyama 1991, eq. 40–42),
/// with s fixed to 1 unless `with_scale`. Points are the columns. Throws ContractError when the
/// sizes differ or there are fewer than 3 points.
Similarity3 umeyamaAlignment(const Eigen::Matrix3Xd& src, const Eigen::Matrix3Xd& dst,
                             bool with_scale);

/// How the estimate is aligned to the ground truth before the ATE.
enum class Alignment {
  None,  ///< compare positions as given
  SE3,   ///< rigid Umeyama alignment (the standard ATE)
  Sim3,  ///< Umeyama alignment with scale (monocular-style)
};

/// Absolute trajectory error of the positions [translation units].
struct AteResult {
  double rmse = 0.0;
  double mean = 0.0;
  double median = 0.0;
  double max = 0.0;
  Similarity3 alignment;       ///< maps the estimate into the ground-truth frame
  std::vector<double> errors;  ///< ‖t_gt,i − (s·R·t_est,i + t)‖ per pose
};

/// ATE of `poses_est` against `poses_gt` (positions only, after `alignment`). Throws
/// ContractError on a length mismatch or fewer than 3 poses.
AteResult absoluteTrajectoryError(const PoseList& poses_gt, const PoseList& poses_est,
                                  Alignment alignment = Alignment::SE3);

/// Unit of the RPE step.
enum class DeltaUnit {
  Frames,  ///< pairs (i, i + delta)
  Meters,  ///< pairs (i, j) with j the first frame whose ground-truth path length from i exceeds
           ///< delta (the KITTI segment rule, lastFrameFromSegmentLength)
};

/// Relative pose error settings.
struct RpeParams {
  double delta = 1.0;                  ///< step [frames or m, per `unit`]
  DeltaUnit unit = DeltaUnit::Frames;  ///< how `delta` is measured
  std::size_t stride = 1;              ///< a pair starts every `stride` frames [frames]
};

/// Relative pose error over pose pairs: E_ij = (Q_i⁻¹ Q_j)⁻¹ (P_i⁻¹ P_j), Q ground truth, P
/// estimate.
struct RpeResult {
  std::size_t n_pairs = 0;
  double trans_rmse = 0.0;             ///< sqrt(mean ‖trans(E)‖²) [translation units]
  double trans_mean = 0.0;             ///< mean ‖trans(E)‖ [translation units]
  double rot_mean_deg = 0.0;           ///< mean angle(E) [deg]
  double rot_rmse_deg = 0.0;           ///< sqrt(mean angle(E)²) [deg]
  std::vector<double> trans_errors;    ///< per pair [translation units]
  std::vector<double> rot_errors_deg;  ///< per pair [deg]
  std::vector<std::pair<std::size_t, std::size_t>> pairs;  ///< (i, j) of each pair
};

/// RPE of `poses_est` against `poses_gt`. Throws ContractError on a length mismatch, fewer than 3
/// poses, delta ≤ 0 (or a non-integer frame delta) or stride 0. A delta longer than the trajectory
/// gives n_pairs = 0 and NaN statistics.
RpeResult relativePoseError(const PoseList& poses_gt, const PoseList& poses_est,
                            const RpeParams& params = {});

}  // namespace obm::eval
