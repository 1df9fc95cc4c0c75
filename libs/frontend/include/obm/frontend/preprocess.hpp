#pragma once
/// \file preprocess.hpp
/// Preprocessing of a sweep before registration: non-finite points removed, range crop, voxel grid,
/// N-point sampling (docs/obm-map.md, "Pipeline").
#include <cstddef>
#include <random>

#include "obm/core/point_cloud.hpp"
#include "obm/frontend/params.hpp"

namespace obm::frontend {

/// What preprocess() kept and dropped.
struct PreprocessStats {
  std::size_t points_in = 0;   ///< points of the raw sweep
  std::size_t non_finite = 0;  ///< dropped: a NaN / infinite coordinate
  std::size_t cropped = 0;     ///< dropped: outside [min_range, max_range]
  std::size_t points_out = 0;  ///< points of the result
};

/// Removes non-finite points and points outside [min_range, max_range] (range from the sensor
/// origin); the result keeps frame, time stamp and attributes. `stats` may be null.
PointCloud cleanAndCrop(const PointCloud& sweep, double min_range, double max_range,
                        PreprocessStats* stats = nullptr);

/// cleanAndCrop, then the voxel grid (`voxel`) and the random N-point sample (`max_points`, drawn
/// with `rng`). The result is in the sweep's frame.
PointCloud preprocess(const PointCloud& sweep, const PreprocessParams& params, std::mt19937_64& rng,
                      PreprocessStats* stats = nullptr);

}  // namespace obm::frontend
