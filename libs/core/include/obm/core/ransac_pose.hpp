#pragma once
/// \file ransac_pose.hpp
/// A rigid pose from putative point correspondences, most of which may be wrong: RANSAC over
/// minimal samples (two pairs for a gravity-aligned 4-DoF pose — yaw about z and a translation —
/// three for a full 6-DoF one), the consensus set counted within a distance, then least squares on
/// that set. For correspondences read off a learned matching map, where a weighted mean over every
/// pair (the weighted SVD) is pulled off by the wrong ones.
#include <cstddef>
#include <cstdint>
#include <vector>

#include "obm/core/se3.hpp"

namespace obm {

struct RansacPoseParams {
  bool planar = true;             ///< 4-DoF (yaw + translation) instead of 6-DoF
  int iterations = 1000;          ///< minimal samples drawn
  double inlier_threshold = 0.5;  ///< a pair agrees with a pose when ‖T·s − t‖ is below this
  /// A minimal sample is scored only when its pairs' mutual distances agree (within the inlier
  /// threshold) in both clouds: a rigid motion keeps them, and the test skips most wrong samples.
  bool check_lengths = true;
  /// Planar only: samples whose yaw |θ| exceeds this are skipped [rad] (π = any heading); for
  /// a search restricted to a sector of headings, the rest being another search's.
  double max_yaw = 3.14159265358979323846;
  int refinements = 3;  ///< least-squares passes on the consensus set, each recounting it
  /// Optional, one per pair: the group a pair belongs to (e.g. its source point, when each source
  /// point brings several candidate targets). A pose's consensus then counts groups with at least
  /// one pair within the threshold, so a point is counted once however many of its candidates
  /// agree. Empty = every pair is its own group.
  std::vector<std::size_t> group;
  std::uint64_t seed = 1;
};

struct RansacPoseResult {
  Isometry3d T_target_source = Isometry3d::Identity();
  std::size_t inliers = 0;  ///< groups (pairs) with a pair within the threshold at the pose
  std::vector<std::size_t> inlier;  ///< their indices
  bool ok = false;                  ///< false when no sample was scored (too few pairs)
};

/// Pairs (source[i], target[i]); `weights` (optional, same size, ≥ 0) weight the least squares.
/// Throws ContractError when the sizes differ or a parameter is out of range.
RansacPoseResult ransacPose(const std::vector<Eigen::Vector3d>& source,
                            const std::vector<Eigen::Vector3d>& target,
                            const RansacPoseParams& params,
                            const std::vector<double>& weights = {});

/// Weighted least-squares rigid pose of the pairs `idx`: yaw + translation when `planar`, else
/// the full rotation (Kabsch / Umeyama without scale). Weights empty = all 1.
Isometry3d fitRigidPose(const std::vector<Eigen::Vector3d>& source,
                        const std::vector<Eigen::Vector3d>& target,
                        const std::vector<std::size_t>& idx, bool planar,
                        const std::vector<double>& weights = {});

}  // namespace obm
