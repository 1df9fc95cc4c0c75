#pragma once
/// \file cloud_ops.hpp
/// Small point-cloud operations shared by the front-end, the data generators and the tools.
#include <cstdint>
#include <random>
#include <vector>

#include "obm/core/point_cloud.hpp"

namespace obm {

/// Voxel-grid down-sampling: one point per occupied voxel of edge `voxel` [m], the centroid of the
/// voxel's points (intensity and colour averaged, the colour rounded). Output order follows the first
/// occurrence of each voxel in the input, so the result is deterministic. `voxel` <= 0 returns a
/// copy.
PointCloud voxelDownsample(const PointCloud& cloud, double voxel);

/// The voxel of edge `voxel` [m] (> 0) of every point, as ids 0, 1, 2, ... in the order of each
/// voxel's first point (`ids[i]` for `points[i]`); returns the number of occupied voxels. The
/// grouping voxelDownsample averages over, for callers that merge attributes of their own.
std::size_t voxelIds(const std::vector<Vector3f>& points, double voxel,
                     std::vector<std::uint32_t>& ids);

/// `n` distinct random points (partial Fisher–Yates); all of them, shuffled, if the cloud has
/// fewer. `indices_out` (optional) receives the chosen input indices.
PointCloud randomSubset(const PointCloud& cloud, std::size_t n, std::mt19937_64& rng,
                        std::vector<std::size_t>* indices_out = nullptr);

/// Keeps the points whose range ‖p‖ from the frame origin is within [min_range, max_range].
PointCloud cropRange(const PointCloud& cloud, double min_range, double max_range);

/// The ground plane of a gravity-aligned sweep, n·p + d = 0 with n·z > 0 (n unit), fitted by
/// RANSAC (threshold 0.15 m, normals within `max_tilt_deg` of z) to the lowest third of the
/// points. Returns false when no plane holds 10 % of those points (no ground seen).
bool fitGroundPlane(const PointCloud& cloud, std::mt19937_64& rng, Eigen::Vector4d* plane,
                    double max_tilt_deg = 20.0);

/// Drops the points less than `band` [m] above the fitted ground plane (and those below it):
/// the road of a LiDAR sweep, whose scan rings move with the sensor and so look the same in
/// two sweeps metres apart, pulling a feature match towards "not moved". Returns the cloud
/// unchanged when no ground plane is found. Deterministic for a given `seed`. `indices_out`
/// (optional) receives the kept input indices.
PointCloud removeGround(const PointCloud& cloud, double band, std::uint64_t seed = 1,
                        std::vector<std::size_t>* indices_out = nullptr);

}  // namespace obm
