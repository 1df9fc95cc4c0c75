#pragma once
/// \file free_space.hpp
/// Free-space agreement of two sensor sweeps at a pose (docs/registration.md, "Free space"): a
/// sensor that measured a return at range r along a ray has seen the space before r empty. A pose
/// that puts the other sweep's points into that space contradicts what was measured. Along a
/// street of repeated facades a pose slid by a block pairs nearly every point with a surface (the
/// facades line up either way), but it moves the parked cars, poles and trees into the open road
/// the other sweep looked through, and its facades into the gaps of the cross streets: the
/// inlier counts cannot tell the two poses apart, the free space can.
#include <cstddef>
#include <vector>

#include "obm/core/point_cloud.hpp"
#include "obm/core/se3.hpp"

namespace obm {
class ConfigNode;
}  // namespace obm

namespace obm::registration {

/// How a sensor's frame is laid out, which sets the axis the range image is centred on.
enum class FreeSpaceSensor {
  Lidar,   ///< x forward, y left, z up (a LiDAR sweep, KITTI's Velodyne frame)
  Camera,  ///< x right, y down, z forward (a depth camera, the OpenCV / TUM optical frame)
};

/// Settings of the free-space test (YAML `free_space:` of the OBMNet matcher).
struct FreeSpaceParams {
  /// The range image is in azimuth and elevation about the sensor's forward axis, so a camera's
  /// field of view, about its optical axis, falls on the image's fine middle cells instead of
  /// its pole (where the cells would be thin wedges).
  FreeSpaceSensor sensor = FreeSpaceSensor::Lidar;
  double azimuth_step_deg = 2.0;    ///< range-image column width [deg]
  double elevation_step_deg = 2.0;  ///< range-image row height [deg]
  /// A point conflicts when it lies closer than the cell's nearest return by more than
  /// margin + relative_margin · range [m]: the cell is a cone, so the nearest return in it bounds
  /// the free space of every ray in it only up to the cone's spread.
  double margin = 0.5;
  double relative_margin = 0.1;
  double min_range = 1.0;  ///< [m] points nearer the sensor are not tested (the vehicle itself)

  /// Throws ConfigError naming the bad key.
  void validate() const;
  /// Reads the keys of `node` (unknown keys rejected with their line).
  static FreeSpaceParams load(const ConfigNode& node);
  /// The settings for depth-camera frames in metres (indoor RGB-D): camera axes, 1° cells, a
  /// 5 cm + 5 % margin (depth noise of a few centimetres at 3 m), points from 0.2 m.
  static FreeSpaceParams depthCamera();
};

/// The nearest return per (azimuth, elevation) cell of a sweep seen from its sensor at the
/// origin of the sweep's frame (the axes of FreeSpaceParams::sensor).
class RangeImage {
 public:
  RangeImage(const std::vector<Vector3f>& points_sensor, const FreeSpaceParams& params);

  /// Whether `p_sensor` (this sweep's frame) lies in space this sweep has seen empty.
  bool inFreeSpace(const Vector3f& p_sensor) const;

  /// How many of `points` (in frame B) lie in this sweep's free space when moved by
  /// T_sensor_B (this sweep's frame ← B).
  std::size_t countConflicts(const std::vector<Vector3f>& points, const Isometry3d& T_sensor_B) const;

 private:
  /// Cell index of a direction, or -1 outside the image.
  long cell(const Vector3f& p, float& range) const;

  FreeSpaceParams params_;
  int cols_ = 0;
  int rows_ = 0;
  std::vector<float> nearest_;  ///< per cell; +inf = no return
};

/// The conflicts of a pose both ways: the source points in the target's free space at
/// T_target_source and the target points in the source's free space at its inverse.
struct FreeSpaceConflicts {
  std::size_t source_in_target = 0;
  std::size_t target_in_source = 0;
  std::size_t num_source = 0;
  std::size_t num_target = 0;
  /// (source_in_target + target_in_source) / (num_source + num_target); 0 for empty sweeps.
  double ratio() const;
};

/// Both range images are built once per pair and reused for every candidate pose.
class FreeSpaceCheck {
 public:
  FreeSpaceCheck(const std::vector<Vector3f>& source, const std::vector<Vector3f>& target,
                 const FreeSpaceParams& params);
  FreeSpaceConflicts conflicts(const Isometry3d& T_target_source) const;

 private:
  const std::vector<Vector3f>& source_;
  const std::vector<Vector3f>& target_;
  RangeImage source_image_;
  RangeImage target_image_;
};

/// The pose to keep among `T_target_source` (several hypotheses of one pair): the largest
/// scores[k] · max(0, 1 − weight·r_k), the first on ties; 0 when there is one pose. `scores` has
/// one entry per pose.
std::size_t chooseByFreeSpace(const std::vector<Isometry3d>& T_target_source,
                              const std::vector<double>& scores, const FreeSpaceCheck& check,
                              double weight);

}  // namespace obm::registration
