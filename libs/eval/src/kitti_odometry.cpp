// The KITTI odometry metric, written from the definition of the official development kit
// (devkit_odometry/cpp/evaluate_odometry.cpp: trajectoryDistances, lastFrameFromSegmentLength,
// rotationError, translationError, calcSequenceErrors, saveStats / saveErrorPlots).
#include "obm/eval/kitti_odometry.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <string>

#include "obm/core/errors.hpp"

namespace obm::eval {

std::vector<double> trajectoryDistances(const PoseList& poses) {
  std::vector<double> dist;
  if (poses.empty()) return dist;
  dist.reserve(poses.size());
  dist.push_back(0.0);
  for (std::size_t i = 1; i < poses.size(); ++i)
    dist.push_back(dist.back() + (poses[i].translation() - poses[i - 1].translation()).norm());
  return dist;
}

std::optional<std::size_t> lastFrameFromSegmentLength(const std::vector<double>& dist,
                                                      std::size_t first_frame, double length) {
  if (first_frame >= dist.size()) return std::nullopt;
  const double target = dist[first_frame] + length;
  // Strictly greater, as the devkit: a segment ends at the first frame beyond the target length.
  for (std::size_t i = first_frame; i < dist.size(); ++i)
    if (dist[i] > target) return i;
  return std::nullopt;
}

std::vector<KittiSegmentError> kittiSegmentErrors(const PoseList& poses_gt,
                                                  const PoseList& poses_pred,
                                                  const KittiOdometryParams& params) {
  if (poses_gt.size() != poses_pred.size())
    throw ContractError("kittiSegmentErrors: ground truth has " + std::to_string(poses_gt.size()) +
                        " poses but the estimate has " + std::to_string(poses_pred.size()));
  if (params.step_size == 0) throw ContractError("kittiSegmentErrors: step_size must be > 0");
  if (!(params.frame_period > 0.0))
    throw ContractError("kittiSegmentErrors: frame_period must be > 0");
  for (double len : params.lengths)
    if (!(len > 0.0))
      throw ContractError("kittiSegmentErrors: segment length " + std::to_string(len) +
                          " must be > 0");

  // The devkit works with general 4×4 matrices and a general inverse; KITTI's ground-truth
  // rotations are orthonormal only to ~1e-7, so the same is done here rather than Rᵀ.
  const std::vector<double> dist = trajectoryDistances(poses_gt);
  std::vector<KittiSegmentError> out;
  for (std::size_t first = 0; first < poses_gt.size(); first += params.step_size) {
    const Eigen::Matrix4d gt_first_inv = poses_gt[first].matrix().inverse();
    const Eigen::Matrix4d pred_first_inv = poses_pred[first].matrix().inverse();
    for (double len : params.lengths) {
      const std::optional<std::size_t> last = lastFrameFromSegmentLength(dist, first, len);
      if (!last) continue;
      const Eigen::Matrix4d delta_gt = gt_first_inv * poses_gt[*last].matrix();
      const Eigen::Matrix4d delta_pred = pred_first_inv * poses_pred[*last].matrix();
      // Residual motion of the segment; the devkit's order inv(Δpred)·Δgt. Its inverse
      // inv(Δgt)·Δpred has the same trace and the same translation norm.
      const Eigen::Matrix4d E = delta_pred.inverse() * delta_gt;
      const double d = 0.5 * (E(0, 0) + E(1, 1) + E(2, 2) - 1.0);
      const double r_err = std::acos(std::max(std::min(d, 1.0), -1.0));
      const double t_err = E.block<3, 1>(0, 3).norm();
      const double num_frames = static_cast<double>(*last - first + 1);
      KittiSegmentError s;
      s.first_frame = first;
      s.last_frame = *last;
      s.r_err = r_err / len;
      s.t_err = t_err / len;
      s.length = len;
      s.speed = len / (params.frame_period * num_frames);
      out.push_back(s);
    }
  }
  return out;
}

KittiOdometryResult summarizeKittiSegments(std::vector<KittiSegmentError> segments,
                                           const KittiOdometryParams& params) {
  constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
  // The published numbers: t_err as a percentage, r_err converted from rad/m to deg/100 m.
  constexpr double kTScale = 100.0;
  constexpr double kRScale = kRadToDeg * 100.0;
  KittiOdometryResult r;
  r.n_segments = segments.size();
  double t_sum = 0.0, r_sum = 0.0;
  for (const KittiSegmentError& s : segments) {
    t_sum += s.t_err;
    r_sum += s.r_err;
  }
  const double n = static_cast<double>(segments.size());
  r.t_err_percent = segments.empty() ? kNaN : kTScale * t_sum / n;
  r.r_err_deg_per_100m = segments.empty() ? kNaN : kRScale * r_sum / n;
  for (double len : params.lengths) {
    KittiLengthStats l;
    l.length = len;
    double lt = 0.0, lr = 0.0;
    for (const KittiSegmentError& s : segments) {
      if (s.length != len) continue;
      ++l.n;
      lt += s.t_err;
      lr += s.r_err;
    }
    l.t_err_percent = l.n == 0 ? kNaN : kTScale * lt / static_cast<double>(l.n);
    l.r_err_deg_per_100m = l.n == 0 ? kNaN : kRScale * lr / static_cast<double>(l.n);
    r.per_length.push_back(l);
  }
  r.segments = std::move(segments);
  return r;
}

KittiOdometryResult evaluateKittiOdometry(const PoseList& poses_gt, const PoseList& poses_pred,
                                          const KittiOdometryParams& params) {
  return summarizeKittiSegments(kittiSegmentErrors(poses_gt, poses_pred, params), params);
}

}  // namespace obm::eval
