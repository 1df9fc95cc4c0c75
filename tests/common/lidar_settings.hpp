#pragma once
/// \file lidar_settings.hpp
/// How the LiDAR accuracy tests feed real sweeps to the LiDAR models and their ICP (header-only;
/// the test links obm::core and obm::registration): one place for the tests of
/// tests/registration and tests/frontend that register real KITTI sweeps.
#include "obm/core/cloud_ops.hpp"
#include "obm/core/point_cloud.hpp"
#include "obm/registration/params.hpp"

namespace obm::test {

/// A LiDAR sweep as the LiDAR models see it: 2–50 m, 0.3 m voxels.
inline PointCloud lidarCloud(const PointCloud& raw) {
  return voxelDownsample(cropRange(raw, 2.0, 50.0), 0.3);
}

/// ICP settings of the LiDAR accuracy tests (metres): a 1 m gate, Huber 0.2 m.
inline registration::IcpParams lidarIcp() {
  registration::IcpParams icp;
  icp.max_correspondence_distance = 1.0;
  icp.initial_max_correspondence_distance = 1.0;
  icp.kernel_scale = 0.2;
  return icp;
}

/// Confidence settings of the LiDAR accuracy tests: inliers within 0.3 m.
inline registration::ConfidenceParams lidarConfidence() {
  registration::ConfidenceParams conf;
  conf.inlier_threshold = 0.3;
  return conf;
}

}  // namespace obm::test
