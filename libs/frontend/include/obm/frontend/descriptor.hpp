#pragma once
/// \file descriptor.hpp
/// A scan-context-like place descriptor (Kim & Kim, "Scan Context: Egocentric Spatial Descriptor
/// for Place Recognition within 3D Point Cloud Map", IROS 2018): the sensor's surroundings are cut
/// into `rings` × `sectors` polar bins in the x–y plane and each bin holds the maximum height
/// (z + height_offset, 0 for an empty bin) of its points. Two descriptors are compared column-wise
/// (sectors) with the cosine distance, under every cyclic sector shift, so the distance does not
/// depend on the heading; the best shift also gives a coarse relative yaw.
#include <Eigen/Core>

#include "obm/core/point_cloud.hpp"
#include "obm/frontend/params.hpp"

namespace obm::frontend {

/// rings × sectors matrix of bin heights [m].
struct PlaceDescriptor {
  Eigen::MatrixXf bins;  ///< row = ring (0 = nearest), column = sector (0 = azimuth −π)
  bool empty() const { return bins.size() == 0; }
};

/// Builds the descriptor of a cloud in a sensor frame with z up (points beyond max_range and
/// non-finite points ignored).
PlaceDescriptor computeDescriptor(const PointCloud& cloud, const DescriptorParams& params);

/// Result of comparing two descriptors.
struct DescriptorMatch {
  double distance = 1.0;  ///< mean cosine distance over the sectors both have, in [0, 1] (2 = none)
  int shift = 0;          ///< sectors `b` is shifted by in the best alignment
  double yaw = 0.0;       ///< [rad] yaw of T_b_a (a's frame in b's) implied by the shift
};

/// Distance of two descriptors of the same size, minimised over the cyclic sector shifts of `b`.
/// Columns empty in either descriptor are left out; with no common column the distance is 1.
DescriptorMatch compareDescriptors(const PlaceDescriptor& a, const PlaceDescriptor& b);

}  // namespace obm::frontend
