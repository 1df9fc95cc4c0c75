#pragma once
// Synthetic scans with known geometry for the mapping tests.
#include <Eigen/Geometry>
#include <cmath>

#include "obm/core/point_cloud.hpp"
#include "obm/core/se3.hpp"

namespace obm::test {

/// Points of a wall x = distance in the sensor frame, y ∈ (−half_width, half_width),
/// z ∈ (−half_height, half_height), on a grid of `step` with samples at cell middles so that no
/// point lies on a voxel boundary of a grid aligned with `step` multiples.
inline PointCloud wallCloud(double distance, double half_width, double half_height, double step,
                            bool with_color = false) {
  PointCloud c;
  for (double y = -half_width + 0.5 * step; y < half_width; y += step)
    for (double z = -half_height + 0.5 * step; z < half_height; z += step) {
      c.points.emplace_back(static_cast<float>(distance), static_cast<float>(y),
                            static_cast<float>(z));
      if (with_color) c.colors.emplace_back(220, 30, 40);
    }
  return c;
}

/// Ray-casts a closed axis-aligned box [lo, hi] (the room, world frame) from a sensor at
/// T_world_sensor inside it; returns the hits in the SENSOR frame. Beams on a regular
/// elevation × azimuth grid like a spinning LiDAR.
inline PointCloud boxRoomScan(const Eigen::Vector3d& lo, const Eigen::Vector3d& hi,
                              const Isometry3d& T_world_sensor, int azimuth_steps = 180,
                              double elev_min_deg = -60.0, double elev_max_deg = 60.0,
                              double elev_step_deg = 5.0) {
  PointCloud c;
  const Eigen::Vector3d o = T_world_sensor.translation();
  const Eigen::Matrix3d R = T_world_sensor.linear();
  for (double el = elev_min_deg; el <= elev_max_deg + 1e-9; el += elev_step_deg)
    for (int a = 0; a < azimuth_steps; ++a) {
      const double az = 2.0 * M_PI * a / azimuth_steps;
      const double e = el * kDegToRad;
      const Eigen::Vector3d d_s(std::cos(e) * std::cos(az), std::cos(e) * std::sin(az),
                                std::sin(e));
      const Eigen::Vector3d d = R * d_s;
      double t = std::numeric_limits<double>::infinity();
      for (int k = 0; k < 3; ++k) {
        if (d[k] > 1e-12) t = std::min(t, (hi[k] - o[k]) / d[k]);
        if (d[k] < -1e-12) t = std::min(t, (lo[k] - o[k]) / d[k]);
      }
      c.points.push_back((t * d_s).cast<float>());
    }
  return c;
}

}  // namespace obm::test
