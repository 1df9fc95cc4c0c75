#pragma once
/// \file frame_stream.hpp
/// Every dataset layout the tools play, behind one streaming reader: frames in order, each a cloud
/// in its sensor frame with its time stamp, and the ground truth of the frames when the dataset
/// has one. obm-map plays it; obm-octomap integrates it along a trajectory.
///
/// The layouts (io::detectDatasetKind tells them apart): KITTI odometry folders, the RGB-D folders
/// (TUM RGB-D, ICL-NUIM, 7-Scenes, Redwood) and MRPT rawlogs.
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "obm/core/point_cloud.hpp"
#include "obm/core/se3.hpp"
#include "obm/io/dataset_kind.hpp"
#include "obm/io/kitti.hpp"

namespace obm::io {

/// How frames are turned into clouds (the `input:` map of obm-map's configuration holds the same).
struct FrameStreamOptions {
  /// Ground-truth (or reference) trajectory to use instead of the layout's own ("" = the layout's):
  /// KITTI format (12 numbers per line, one pose per frame) or TUM format (associated by time).
  std::string ground_truth;
  int rgbd_stride = 1;          ///< RGB-D: every n-th pixel row and column is back-projected
  bool rgbd_color = false;      ///< RGB-D: attach the colour image registered to the depth
  double rgbd_edge_jump = 0.0;  ///< RGB-D: drop depth-edge pixels (removeDepthEdges); 0 = keep
  double depth_min = 0.0;       ///< [m] RGB-D and rawlog depth: nearer depth is dropped
  double depth_max = 0.0;       ///< [m] RGB-D and rawlog depth: farther is dropped; 0 = keep all
  /// [s] association window of TUM-format time stamps (depth, colour, ground truth).
  double max_time_difference = 0.02;
  std::string sensor_label;         ///< rawlogs: only this sensor label ("" = every one)
  double velodyne_min_range = 1.0;  ///< [m] rawlog Velodyne scans
  std::string log_component = "io";  ///< the component named in warnings (the app's name)
};

/// Ground truth of the frames, in the body frame of the clouds (the sensor frame): index-aligned
/// with the time stamps it was asked for, nullopt where a frame has none.
struct FrameGroundTruth {
  std::string path;  ///< what was read ("" = none)
  std::vector<std::optional<Isometry3d>> T_world_body;
};

class FrameStream {
 public:
  /// Opens `input` (a folder, or a .rawlog / .rawlog.gz file). IoError / FormatError naming the
  /// file for a missing or inconsistent layout, or a missing `options.ground_truth`.
  static std::unique_ptr<FrameStream> open(const std::string& input,
                                           const FrameStreamOptions& options = {});

  virtual ~FrameStream() = default;
  virtual DatasetKind kind() const = 0;
  /// Frames in the input; 0 when unknown before reading (rawlogs).
  virtual std::size_t size() const = 0;
  /// [s] the time stamp of every frame, before any is read (a rawlog is read once without
  /// building its clouds for them).
  virtual std::vector<double> timestamps() const = 0;
  /// Reads the next frame (points in the sensor frame, `timestamp` set); false at the end. A frame
  /// that cannot be read (a corrupt scan file) comes back empty, is counted in readErrors() and
  /// named in a warning.
  virtual bool next(PointCloud& cloud) = 0;
  /// Moves past the next frame without building its cloud where the layout allows; false at the end.
  virtual bool skip() {
    PointCloud unused;
    return next(unused);
  }
  /// Frames that could not be read.
  std::size_t readErrors() const { return read_errors_; }
  /// Rotation from the first sensor frame to a frame with z up (for maps and pictures): identity
  /// for LiDARs, the optical → x-forward/z-up rotation for depth cameras.
  virtual Isometry3d T_up_sensor() const { return Isometry3d::Identity(); }
  /// The KITTI calibration (KITTI trajectories are camera-0 poses), nullptr for other layouts.
  virtual const KittiCalib* kittiCalib() const { return nullptr; }
  /// Ground truth of the frames stamped `timestamps` (the frames read, in order): KITTI-format
  /// files are index-aligned, TUM-format files associated by time stamp within `max_dt`.
  virtual FrameGroundTruth groundTruth(const std::vector<double>& timestamps,
                                       double max_dt) const = 0;

 protected:
  std::size_t read_errors_ = 0;
};

}  // namespace obm::io
