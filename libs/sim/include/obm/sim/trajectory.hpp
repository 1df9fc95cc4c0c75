#pragma once
/// \file trajectory.hpp
/// A time-stamped sensor trajectory T_world_sensor(t) with interpolation (for per-column poses of
/// a spinning LiDAR and for resampling motion-capture ground truth to a camera's frame rate), and
/// loaders of the KITTI and TUM ground-truth files.
#include <Eigen/Geometry>
#include <cstddef>
#include <string>
#include <vector>

namespace obm::sim {

/// Poses of one sensor over time. `poses[i]` is T_world_sensor at `stamps[i]`; the sensor frame
/// is the LiDAR frame (x forward, y left, z up) or the camera's optical frame (x right, y down,
/// z forward) depending on what the trajectory drives.
struct Trajectory {
  std::vector<double> stamps;            ///< [s], strictly increasing
  std::vector<Eigen::Isometry3d> poses;  ///< T_world_sensor
  std::string source;                    ///< file or generator, for messages

  std::size_t size() const noexcept { return poses.size(); }
  bool empty() const noexcept { return poses.empty(); }
  void push_back(double t, const Eigen::Isometry3d& T_world_sensor);

  /// Pose at time t: linear in translation, spherical-linear in rotation between the two
  /// neighbouring samples; clamped to the first / last pose outside the time span.
  Eigen::Isometry3d interpolate(double t) const;

  /// Sum of the distances between consecutive positions [m].
  double length() const;
  /// Largest distance between any position and the first one [m].
  double extent() const;

  /// Throws FormatError (naming `source` and the pose index) unless stamps and poses have the
  /// same size, stamps are strictly increasing and rotations are orthonormal.
  void validate() const;

  /// The first `n` poses (all when n = 0 or n ≥ size()).
  Trajectory head(std::size_t n) const;

  /// Samples at `rate_hz` from the first stamp to the last one (interpolated).
  Trajectory resampled(double rate_hz) const;

  /// Re-expresses the poses: T_newworld_newsensor = T_newworld_world · T_world_sensor ·
  /// T_sensor_newsensor.
  Trajectory transformed(const Eigen::Isometry3d& T_newworld_world,
                         const Eigen::Isometry3d& T_sensor_newsensor) const;
};

/// The KITTI odometry calibration the simulator writes and uses by default: sequence 00's
/// (drive 2011_10_03) rectified projections P0..P3 and Tr (velodyne → left camera).
struct KittiCalibration {
  Eigen::Isometry3d T_cam0_velo = Eigen::Isometry3d::Identity();  ///< Tr
  double P[4][12] = {};                                           ///< rows of P0..P3
  /// KITTI 00's values (Tr projected onto SO(3), a change below 1e-7).
  static KittiCalibration kitti00();
};

/// Reads a KITTI pose file (camera frame, T_cam0_0_cam0_i per line) and converts it to LiDAR
/// poses T_velo0_velo_i = Tr⁻¹ · T_cam0_0_cam0_i · Tr (world = first LiDAR frame). Stamps come
/// from `times_file` when not empty, otherwise 0.1 s apart. `max_poses` > 0 keeps the first ones.
/// Throws IoError / FormatError naming the file and line.
Trajectory loadKittiTrajectory(const std::string& poses_file, const std::string& times_file,
                               const Eigen::Isometry3d& T_cam0_velo, std::size_t max_poses = 0);

/// Reads a TUM ground-truth file (`timestamp tx ty tz qx qy qz qw`, camera optical centre in the
/// motion-capture frame). Throws IoError / FormatError naming the file and line.
Trajectory loadTumTrajectory(const std::string& file, std::size_t max_poses = 0);

}  // namespace obm::sim
