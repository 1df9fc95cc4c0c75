#pragma once
/// \file cloud_ops.hpp
/// Small point-cloud operations shared by the front-end, the data generators and the tools.
#include <random>

#include "obm/core/point_cloud.hpp"

namespace obm {

/// Voxel-grid down-sampling: one point per occupied voxel of edge `voxel` [m], the centroid of the
/// voxel's points (intensity and colour averaged, the colour rounded). Output order follows the first
/// occurrence of each voxel in the input, so the result is deterministic. `voxel` <= 0 returns a
/// copy.
PointCloud voxelDownsample(const PointCloud& cloud, double voxel);

/// `n` distinct random points (partial Fisher–Yates); all of them, shuffled, if the cloud has
/// fewer. `indices_out` (optional) receives the chosen input indices.
PointCloud randomSubset(const PointCloud& cloud, std::size_t n, std::mt19937_64& rng,
                        std::vector<std::size_t>* indices_out = nullptr);

/// Keeps the points whose range ‖p‖ from the frame origin is within [min_range, max_range].
PointCloud cropRange(const PointCloud& cloud, double min_range, double max_range);

}  // namespace obm
