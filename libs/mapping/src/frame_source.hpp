#pragma once
// Private: the sequences obm-octomap reads, behind one interface (frames read in increasing order).
#include <memory>
#include <string>
#include <vector>

#include "obm/core/point_cloud.hpp"
#include "obm/io/dataset_kind.hpp"
#include "obm/io/kitti.hpp"

namespace obm::mapping::detail {

/// The layouts obm-octomap reads (io::detectDatasetKind tells them apart).
using InputKind = io::DatasetKind;

class FrameSource {
 public:
  virtual ~FrameSource() = default;
  virtual InputKind kind() const = 0;
  /// Number of frames.
  virtual std::size_t size() const = 0;
  /// [s] time stamp of every frame.
  virtual const std::vector<double>& timestamps() const = 0;
  /// The calibration when the input is a KITTI folder (KITTI trajectories are camera poses).
  virtual const io::KittiCalib* kittiCalib() const { return nullptr; }
  /// Frame i in its sensor frame (the frame the trajectory's poses refer to). Calls must come in
  /// increasing order of i (streamed inputs cannot go back).
  virtual PointCloud cloud(std::size_t i, bool with_color) = 0;
};

/// Opens `input` of layout `kind`. Throws IoError / FormatError naming the file for a missing or
/// inconsistent layout.
/// \param kitti_poses_path a KITTI-format trajectory to check against the scans ("" = none)
/// \param rgbd_max_depth [m] RGB-D depth cut (0 = none)
std::unique_ptr<FrameSource> openFrameSource(const std::string& input, InputKind kind,
                                             const std::string& kitti_poses_path,
                                             double rgbd_max_depth);

}  // namespace obm::mapping::detail
