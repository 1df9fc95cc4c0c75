#include "obm/eval/trajectory_metrics.hpp"

#include <Eigen/SVD>
#include <algorithm>
#include <cmath>
#include <string>

#include "obm/core/errors.hpp"
#include "obm/eval/statistics.hpp"

namespace obm::eval {

Isometry3d Similarity3::operator*(const Isometry3d& T) const {
  Isometry3d out = Isometry3d::Identity();
  out.linear() = R * T.linear();
  out.translation() = s * (R * T.translation()) + t;
  return out;
}

Similarity3 umeyamaAlignment(const Eigen::Matrix3Xd& src, const Eigen::Matrix3Xd& dst,
                             bool with_scale) {
  if (src.cols() != dst.cols())
    throw ContractError("umeyamaAlignment: " + std::to_string(src.cols()) + " source points but " +
                        std::to_string(dst.cols()) + " target points");
  if (src.cols() < 3)
    throw ContractError("umeyamaAlignment: needs at least 3 points, got " +
                        std::to_string(src.cols()));
  const double n = static_cast<double>(src.cols());
  const Eigen::Vector3d mu_src = src.rowwise().mean();
  const Eigen::Vector3d mu_dst = dst.rowwise().mean();
  const Eigen::Matrix3Xd src_c = src.colwise() - mu_src;
  const Eigen::Matrix3Xd dst_c = dst.colwise() - mu_dst;
  // Umeyama eq. (38): cross-covariance Σ_xy = (1/n) Σ (y_i − μ_y)(x_i − μ_x)ᵀ, y = dst, x = src.
  const Eigen::Matrix3d sigma = dst_c * src_c.transpose() / n;
  Eigen::JacobiSVD<Eigen::Matrix3d> svd(sigma, Eigen::ComputeFullU | Eigen::ComputeFullV);
  // Eq. (39)/(43): S = diag(1, 1, −1) when det(U)·det(V) < 0 so that R is a proper rotation
  // (covers the rank-2 case of planar point sets too).
  Eigen::Vector3d S(1.0, 1.0, 1.0);
  if (svd.matrixU().determinant() * svd.matrixV().determinant() < 0.0) S(2) = -1.0;
  Similarity3 out;
  out.R = svd.matrixU() * S.asDiagonal() * svd.matrixV().transpose();  // eq. (40)
  if (with_scale) {
    const double var_src = src_c.squaredNorm() / n;  // eq. (36)
    if (!(var_src > 0.0))
      throw ContractError("umeyamaAlignment: source points coincide, scale is undefined");
    out.s = svd.singularValues().dot(S) / var_src;  // eq. (42)
  }
  out.t = mu_dst - out.s * out.R * mu_src;  // eq. (41)
  return out;
}

namespace {

void checkTrajectories(const char* what, const PoseList& gt, const PoseList& est) {
  if (gt.size() != est.size())
    throw ContractError(std::string(what) + ": ground truth has " + std::to_string(gt.size()) +
                        " poses but the estimate has " + std::to_string(est.size()) +
                        " (associate them first)");
  if (gt.size() < 3)
    throw ContractError(std::string(what) + ": needs at least 3 poses, got " +
                        std::to_string(gt.size()));
}

Eigen::Matrix3Xd positions(const PoseList& poses) {
  Eigen::Matrix3Xd p(3, static_cast<Eigen::Index>(poses.size()));
  for (std::size_t i = 0; i < poses.size(); ++i)
    p.col(static_cast<Eigen::Index>(i)) = poses[i].translation();
  return p;
}

}  // namespace

AteResult absoluteTrajectoryError(const PoseList& poses_gt, const PoseList& poses_est,
                                  Alignment alignment) {
  checkTrajectories("absoluteTrajectoryError", poses_gt, poses_est);
  const Eigen::Matrix3Xd p_gt = positions(poses_gt);
  const Eigen::Matrix3Xd p_est = positions(poses_est);
  AteResult r;
  if (alignment != Alignment::None)
    r.alignment = umeyamaAlignment(p_est, p_gt, alignment == Alignment::Sim3);
  r.errors.reserve(poses_gt.size());
  for (Eigen::Index i = 0; i < p_gt.cols(); ++i)
    r.errors.push_back((p_gt.col(i) - r.alignment * Eigen::Vector3d(p_est.col(i))).norm());
  r.rmse = rootMeanSquare(r.errors);
  r.mean = mean(r.errors);
  r.median = median(r.errors);
  r.max = *std::max_element(r.errors.begin(), r.errors.end());
  return r;
}

RpeResult relativePoseError(const PoseList& poses_gt, const PoseList& poses_est,
                            const RpeParams& params) {
  checkTrajectories("relativePoseError", poses_gt, poses_est);
  if (!(params.delta > 0.0))
    throw ContractError("relativePoseError: delta must be > 0, got " +
                        std::to_string(params.delta));
  if (params.stride == 0) throw ContractError("relativePoseError: stride must be > 0");
  const std::size_t n = poses_gt.size();

  RpeResult r;
  if (params.unit == DeltaUnit::Frames) {
    const double rounded = std::round(params.delta);
    if (std::abs(params.delta - rounded) > 1e-9)
      throw ContractError("relativePoseError: a frame delta must be an integer, got " +
                          std::to_string(params.delta));
    const auto d = static_cast<std::size_t>(rounded);
    for (std::size_t i = 0; i + d < n; i += params.stride) r.pairs.emplace_back(i, i + d);
  } else {
    const std::vector<double> dist = trajectoryDistances(poses_gt);
    for (std::size_t i = 0; i < n; i += params.stride) {
      const std::optional<std::size_t> j = lastFrameFromSegmentLength(dist, i, params.delta);
      if (!j) break;  // distances never decrease: no later start can reach delta either
      r.pairs.emplace_back(i, *j);
    }
  }

  for (const auto& [i, j] : r.pairs) {
    // TUM evaluate_rpe / evo: E = (Q_i⁻¹Q_j)⁻¹ · (P_i⁻¹P_j).
    const Isometry3d E =
        relative(poses_gt[i], poses_gt[j]).inverse() * relative(poses_est[i], poses_est[j]);
    r.trans_errors.push_back(E.translation().norm());
    r.rot_errors_deg.push_back(rotationAngle(E.linear()) * kRadToDeg);
  }
  r.n_pairs = r.pairs.size();
  r.trans_rmse = rootMeanSquare(r.trans_errors);
  r.trans_mean = mean(r.trans_errors);
  r.rot_mean_deg = mean(r.rot_errors_deg);
  r.rot_rmse_deg = rootMeanSquare(r.rot_errors_deg);
  return r;
}

}  // namespace obm::eval
