#pragma once
/// \file export.hpp
/// A mapping run in files MRPT's own tools open: a `.simplemap` (keyframe poses with covariance and
/// their point-cloud observations) for `observations2map` and every `mrpt::maps::CSimpleMap`
/// consumer, a `.3Dscene` for `SceneViewer3D`, and trajectories as `CPose3DInterpolator` text.
/// Every file is written atomically (temporary file + rename). No MRPT header here.
#include <string>
#include <vector>

#include "obm/core/point_cloud.hpp"
#include "obm/core/se3.hpp"

namespace obm::mrpt_bridge {

/// One keyframe of a run, as the simple map stores it.
struct ExportKeyframe {
  double timestamp = 0.0;  ///< [s] UNIX or sequence time
  Isometry3d T_world_sensor = Isometry3d::Identity();
  /// Information of the keyframe's pose over the right twist [ρ; θ] (match_result.hpp); all zero
  /// when unknown (then the covariance is `unconstrained_variance` on the diagonal).
  Matrix6d information = Matrix6d::Zero();
  PointCloud cloud;  ///< the keyframe's points, sensor frame
};

/// Writes a gzip-compressed MRPT `CSimpleMap` (the format of `.simplemap` files): one
/// (CPose3DPDFGaussian, CSensoryFrame) per keyframe; the frame holds one CObservationPointCloud
/// labelled `sensor_label` (sensor pose identity: the keyframe pose is the sensor's) with the
/// keyframe's cloud. Throws IoError naming the file when it cannot be written.
void writeSimpleMap(const std::string& path, const std::vector<ExportKeyframe>& keyframes,
                    const std::string& sensor_label = "OBM_KEYFRAME");

/// One entry of a simple map as read back.
struct SimpleMapEntry {
  double timestamp = 0.0;  ///< of the first point-cloud observation [s]
  Isometry3d T_world_sensor = Isometry3d::Identity();  ///< the pose PDF's mean
  /// The PDF's covariance in MRPT's parameters (x, y, z, yaw, pitch, roll); zero when the PDF is
  /// not a CPose3DPDFGaussian.
  Matrix6d covariance = Matrix6d::Zero();
  PointCloud cloud;  ///< the first CObservationPointCloud's points (its frame)
};

/// Reads an MRPT simple map (what writeSimpleMap writes, or any with point-cloud observations):
/// for checks and tools. Throws IoError / FormatError naming the file.
std::vector<SimpleMapEntry> readSimpleMap(const std::string& path);

/// A trajectory as `mrpt::poses::CPose3DInterpolator::saveToTextFile` writes it: one line
/// `t x y z yaw pitch roll` per pose (t [s], angles [rad]).
void writePoseInterpolatorText(const std::string& path, const std::vector<double>& stamps,
                               const std::vector<Isometry3d>& poses);

/// What the 3-D scene shows.
struct SceneContent {
  std::vector<Isometry3d> trajectory;    ///< estimated sensor poses (drawn as a line, blue)
  std::vector<Isometry3d> ground_truth;  ///< optional, drawn green
  std::vector<Isometry3d> keyframes;     ///< small axes at each keyframe
  PointCloud map_points;                 ///< world frame (coloured by height)
  std::vector<std::pair<Eigen::Vector3d, Eigen::Vector3d>> loops;  ///< loop edges, red
};

/// Writes a gzip-compressed `mrpt::opengl::COpenGLScene` (`.3Dscene`) for `SceneViewer3D`.
void write3DScene(const std::string& path, const SceneContent& content);

}  // namespace obm::mrpt_bridge
