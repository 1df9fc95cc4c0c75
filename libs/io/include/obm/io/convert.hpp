#pragma once
/// \file convert.hpp
/// Dataset conversions behind the `obm-convert` tool: KITTI odometry sequences to MRPT rawlogs
/// and to TUM trajectories, and RGB-D sequences (TUM, ICL-NUIM, 7-Scenes, Redwood layouts) to
/// MRPT rawlogs. Outputs are written atomically: a failure leaves no partial file behind.
#include <cstddef>
#include <functional>
#include <string>

#include "obm/core/se3.hpp"
#include "obm/io/rgbd.hpp"

namespace obm::io {

/// Called after each converted frame with (frames done, frames in total).
using ConvertProgress = std::function<void(std::size_t done, std::size_t total)>;

/// Options of kittiToRawlog().
struct KittiToRawlogOptions {
  std::string sensor_label = "velodyne";  ///< `sensorLabel` of every observation
  /// Pose of the LiDAR on the vehicle, written as `sensorPose`; identity makes the vehicle frame
  /// the LiDAR frame (the frame of groundTruthLidar()).
  Isometry3d T_vehicle_sensor = Isometry3d::Identity();
  /// [s] added to times.txt (KITTI times start at 0 at the first scan, which MRPT takes for an
  /// invalid time stamp; an offset such as the drive's UNIX start time avoids that).
  double time_offset = 0.0;
  std::size_t first = 0;                             ///< first scan converted
  std::size_t count = static_cast<std::size_t>(-1);  ///< scans converted at most (all by default)
  std::size_t stride = 1;                            ///< every stride-th scan (≥ 1)
  int compression_level = 1;                         ///< gzip level 1-9
};

/// Writes one CObservationPointCloud (points with reflectance as intensity, in the LiDAR frame)
/// per scan of the KITTI sequence folder `seq_dir`, time stamps from times.txt. Returns the
/// number of observations written. Throws like KittiSequence / RawlogWriter, ContractError for
/// stride 0 or a first scan past the end.
std::size_t kittiToRawlog(const std::string& seq_dir, const std::string& out_rawlog,
                          const KittiToRawlogOptions& options = {},
                          const ConvertProgress& progress = {});

/// Which body the ground truth of kittiToTum() describes.
enum class KittiPoseFrame {
  Lidar,  ///< T_world_velo, world = the LiDAR frame at the first scan
  Camera  ///< T_world_cam0 as in the poses file (left grey camera)
};

/// Writes the ground truth of a KITTI sequence as a TUM trajectory stamped with times.txt (plus
/// `time_offset`). `poses_path` overrides the ground-truth file (see KittiSequence). Returns the
/// number of poses. Throws IoError when the sequence has no ground truth.
std::size_t kittiToTum(const std::string& seq_dir, const std::string& out_tum, KittiPoseFrame frame,
                       const std::string& poses_path = "", double time_offset = 0.0);

/// Options of rgbdToRawlog().
struct RgbdToRawlogOptions {
  RgbdLayout layout = RgbdLayout::Tum;
  std::string sensor_label = "rgbd";
  /// Pose of the camera's optical frame on the vehicle; identity makes the vehicle frame the
  /// optical frame, so the sequence's ground truth (T_world_camera) is T_world_vehicle.
  Isometry3d T_vehicle_camera = Isometry3d::Identity();
  RgbdSequenceOptions sequence;  ///< association window etc.
  /// [s] added to the frame times (7-Scenes and Redwood frames are stamped k / 30 s from 0, and
  /// MRPT takes a time stamp of 0 for "invalid").
  double time_offset = 0.0;
  std::size_t first = 0;
  std::size_t count = static_cast<std::size_t>(-1);
  std::size_t stride = 1;
  int compression_level = 1;
};

/// Writes one CObservation3DRangeScan (range image in the sequence's raw depth units, intrinsics,
/// sensorPose from T_vehicle_camera, time stamp of the depth image) per depth frame of an RGB-D
/// sequence folder. Returns the number of observations written.
std::size_t rgbdToRawlog(const std::string& dir, const std::string& out_rawlog,
                         const RgbdToRawlogOptions& options = {},
                         const ConvertProgress& progress = {});

}  // namespace obm::io
