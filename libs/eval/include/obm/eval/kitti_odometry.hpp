#pragma once
/// \file kitti_odometry.hpp
/// The KITTI odometry benchmark metric, as defined by the official development kit
/// (devkit_odometry, evaluate_odometry.cpp): relative translation error [%] and rotation error
/// [deg/100 m] averaged over all sub-sequences of 100, 200, …, 800 m that start every 10 frames.
/// Distances are measured along the ground truth. Definitions with equations: docs/metrics.md.
#include <cstddef>
#include <optional>
#include <vector>

#include "obm/core/se3.hpp"

namespace obm::eval {

/// Trajectory of poses `T_world_frame` (KITTI: left-camera poses relative to the first frame),
/// one per frame, index-aligned between estimate and ground truth.
using PoseList = std::vector<Isometry3d>;

/// Constants of the devkit; the defaults are the official benchmark.
struct KittiOdometryParams {
  std::vector<double> lengths = {100, 200, 300, 400, 500, 600, 700, 800};  ///< segment lengths [m]
  std::size_t step_size = 10;  ///< a segment starts every `step_size` frames [frames]
  double frame_period = 0.1;   ///< time between frames, for the speed column [s] (10 Hz)
};

/// The error of one sub-sequence (the devkit's `errors` record, plus its last frame).
struct KittiSegmentError {
  std::size_t first_frame = 0;
  std::size_t last_frame = 0;
  double r_err = 0.0;   ///< rotation error / length [rad/m]
  double t_err = 0.0;   ///< translation error / length [m/m]
  double length = 0.0;  ///< nominal segment length [m]
  double speed = 0.0;   ///< length / (frame_period · (last − first + 1)) [m/s]
};

/// Averages over the segments of one nominal length (the devkit's per-length plots).
struct KittiLengthStats {
  double length = 0.0;              ///< [m]
  std::size_t n = 0;                ///< segments of this length
  double t_err_percent = 0.0;       ///< mean t_err · 100 [%]
  double r_err_deg_per_100m = 0.0;  ///< mean r_err · 180/π · 100 [deg/100 m]
};

/// The benchmark numbers: means over all segments (NaN when there is none).
struct KittiOdometryResult {
  std::size_t n_segments = 0;
  double t_err_percent = 0.0;       ///< mean over segments of t_err · 100 [%]
  double r_err_deg_per_100m = 0.0;  ///< mean over segments of r_err · 180/π · 100 [deg/100 m]
  std::vector<KittiLengthStats> per_length;  ///< one entry per params.lengths, same order
  std::vector<KittiSegmentError> segments;   ///< every evaluated segment
};

/// Cumulative path length along `poses`: dist[0] = 0, dist[i] = dist[i−1] + ‖t_i − t_{i−1}‖ [m].
std::vector<double> trajectoryDistances(const PoseList& poses);

/// The devkit's end of a segment: the first frame i ≥ first_frame whose distance exceeds
/// dist[first_frame] + length (strictly greater); nullopt when the trajectory is too short.
std::optional<std::size_t> lastFrameFromSegmentLength(const std::vector<double>& dist,
                                                      std::size_t first_frame, double length);

/// Errors of every segment of one sequence (the devkit's calcSequenceErrors). Throws
/// ContractError when the two trajectories differ in length.
std::vector<KittiSegmentError> kittiSegmentErrors(const PoseList& poses_gt,
                                                  const PoseList& poses_pred,
                                                  const KittiOdometryParams& params = {});

/// Averages segments, possibly pooled over several sequences (the devkit averages over all
/// segments of all sequences, not over sequences).
KittiOdometryResult summarizeKittiSegments(std::vector<KittiSegmentError> segments,
                                           const KittiOdometryParams& params = {});

/// kittiSegmentErrors + summarizeKittiSegments for one sequence.
KittiOdometryResult evaluateKittiOdometry(const PoseList& poses_gt, const PoseList& poses_pred,
                                          const KittiOdometryParams& params = {});

}  // namespace obm::eval
