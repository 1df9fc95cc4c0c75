#include "obm/frontend/preprocess.hpp"

#include <cmath>

#include "obm/core/cloud_ops.hpp"

namespace obm::frontend {

PointCloud cleanAndCrop(const PointCloud& sweep, double min_range, double max_range,
                        PreprocessStats* stats) {
  PreprocessStats s;
  s.points_in = sweep.size();
  // Compare squared ranges: one pass, no square roots.
  const double min2 = min_range * min_range;
  const double max2 = max_range > 0.0 ? max_range * max_range : INFINITY;
  std::vector<std::size_t> keep;
  keep.reserve(sweep.size());
  for (std::size_t i = 0; i < sweep.size(); ++i) {
    const Vector3f& p = sweep.points[i];
    if (!p.allFinite()) {
      ++s.non_finite;
      continue;
    }
    const double r2 = static_cast<double>(p.squaredNorm());
    if (r2 < min2 || r2 > max2) {
      ++s.cropped;
      continue;
    }
    keep.push_back(i);
  }
  PointCloud out;
  if (keep.size() == sweep.size()) {
    out = sweep;
  } else {
    // select() requires consistent attribute arrays; a sweep with mis-sized attributes keeps
    // only its points.
    const bool attrs_ok = (sweep.intensity.empty() || sweep.intensity.size() == sweep.size()) &&
                          (sweep.colors.empty() || sweep.colors.size() == sweep.size());
    if (attrs_ok) {
      out = sweep.select(keep);
    } else {
      out.points.reserve(keep.size());
      for (std::size_t i : keep) out.points.push_back(sweep.points[i]);
    }
    out.timestamp = sweep.timestamp;
    out.frame_id = sweep.frame_id;
  }
  s.points_out = out.size();
  if (stats) *stats = s;
  return out;
}

PointCloud preprocess(const PointCloud& sweep, const PreprocessParams& params, std::mt19937_64& rng,
                      PreprocessStats* stats) {
  PreprocessStats s;
  PointCloud out = cleanAndCrop(sweep, params.min_range, params.max_range, &s);
  if (params.voxel > 0.0) out = voxelDownsample(out, params.voxel);
  if (params.max_points > 0 && out.size() > params.max_points) {
    PointCloud sampled = randomSubset(out, params.max_points, rng);
    sampled.timestamp = out.timestamp;
    sampled.frame_id = out.frame_id;
    out = std::move(sampled);
  }
  s.points_out = out.size();
  if (stats) *stats = s;
  return out;
}

}  // namespace obm::frontend
