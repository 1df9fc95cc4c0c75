#pragma once
// Private: the inputs obm-map plays, behind one streaming interface, with their ground truth.
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "obm/core/point_cloud.hpp"
#include "obm/core/se3.hpp"
#include "obm/io/dataset_kind.hpp"
#include "obm/io/kitti.hpp"
#include "obm/slam/slam_config.hpp"

namespace obm::slam::detail {

/// The layouts obm-map plays (io::detectDatasetKind tells them apart).
using InputKind = io::DatasetKind;

/// Ground truth of the frames, in the same body frame as the clouds (the sensor frame of the
/// front-end's poses): index-aligned with the frames read, nullopt where a frame has none.
struct GroundTruth {
  std::string path;  ///< file read ("" = none)
  std::vector<std::optional<Isometry3d>> T_world_body;
};

class FrameSource {
 public:
  virtual ~FrameSource() = default;
  virtual InputKind kind() const = 0;
  /// Frames in the input; 0 when unknown before reading (rawlogs).
  virtual std::size_t size() const = 0;
  /// Reads the next frame (points in the sensor frame, `timestamp` set); false at the end. A
  /// frame that cannot be read (a corrupt scan file) comes back empty and is counted.
  virtual bool next(PointCloud& cloud) = 0;
  /// Frames that could not be read.
  virtual std::size_t readErrors() const { return read_errors_; }
  /// Rotation from the first sensor frame to a frame with z up (for the map and the pictures):
  /// identity for LiDARs, the optical → x-forward/z-up rotation for depth cameras.
  virtual Isometry3d T_up_sensor() const { return Isometry3d::Identity(); }
  /// The KITTI calibration (KITTI trajectories are camera-0 poses), nullptr otherwise.
  virtual const io::KittiCalib* kittiCalib() const { return nullptr; }
  /// Ground truth for the first `timestamps.size()` frames read (TUM files are associated by time
  /// stamp within `max_dt`).
  virtual GroundTruth groundTruth(const std::vector<double>& timestamps, double max_dt) const = 0;

 protected:
  std::size_t read_errors_ = 0;
};

/// Opens `input` (IoError / FormatError naming the file for a missing or inconsistent layout).
/// `ground_truth` overrides the layout's own ground truth ("" = the layout's).
std::unique_ptr<FrameSource> openFrameSource(const std::string& input,
                                             const std::string& ground_truth,
                                             const InputParams& params);

}  // namespace obm::slam::detail
