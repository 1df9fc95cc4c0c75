#include "obm/io/convert.hpp"

#include <algorithm>

#include "obm/core/errors.hpp"
#include "obm/io/kitti.hpp"
#include "obm/io/rawlog.hpp"
#include "obm/io/trajectory.hpp"
#include "text_parse.hpp"

namespace obm::io {
namespace {

/// Indices first, first + stride, ... (at most `count` of them) below `size`.
std::vector<std::size_t> selectFrames(std::size_t size, std::size_t first, std::size_t count,
                                      std::size_t stride, const std::string& what) {
  if (stride == 0) throw ContractError(what + ": stride must be at least 1");
  if (first >= size && size > 0)
    throw ContractError(what + ": first frame " + std::to_string(first) + " is past the last (" +
                        std::to_string(size) + " frames)");
  std::vector<std::size_t> idx;
  for (std::size_t i = first; i < size && idx.size() < count; i += stride) idx.push_back(i);
  return idx;
}

}  // namespace

std::size_t kittiToRawlog(const std::string& seq_dir, const std::string& out_rawlog,
                          const KittiToRawlogOptions& options, const ConvertProgress& progress) {
  const KittiSequence seq(seq_dir);
  const auto idx =
      selectFrames(seq.size(), options.first, options.count, options.stride, "kittiToRawlog");
  RawlogWriter writer(out_rawlog, options.compression_level);
  for (std::size_t k = 0; k < idx.size(); ++k) {
    const PointCloud scan = seq.scan(idx[k]);
    writer.writePointCloud(scan, options.T_vehicle_sensor,
                           seq.timestamp(idx[k]) + options.time_offset, options.sensor_label);
    if (progress) progress(k + 1, idx.size());
  }
  writer.close();
  return idx.size();
}

std::size_t kittiToTum(const std::string& seq_dir, const std::string& out_tum, KittiPoseFrame frame,
                       const std::string& poses_path, double time_offset) {
  const KittiSequence seq(seq_dir, poses_path);
  if (!seq.hasGroundTruth())
    throw IoError("KITTI sequence '" + seq_dir +
                  "' has no ground truth (poses.txt, ../../poses/<NN>.txt or --poses)");
  std::vector<double> t = seq.timestamps();
  for (double& x : t) x += time_offset;
  const Trajectory traj = stampPoses(
      frame == KittiPoseFrame::Lidar ? seq.groundTruthLidar() : seq.groundTruthCamera(), t);
  writeTumTrajectory(out_tum, traj);
  return traj.size();
}

std::size_t rgbdToRawlog(const std::string& dir, const std::string& out_rawlog,
                         const RgbdToRawlogOptions& options, const ConvertProgress& progress) {
  const RgbdSequence seq = RgbdSequence::open(dir, options.layout, options.sequence);
  const auto idx =
      selectFrames(seq.size(), options.first, options.count, options.stride, "rgbdToRawlog");
  RawlogWriter writer(out_rawlog, options.compression_level);
  for (std::size_t k = 0; k < idx.size(); ++k) {
    const DepthImage depth = seq.depth(idx[k]);
    writer.writeDepth(depth, seq.depthScale(), seq.intrinsics(), options.T_vehicle_camera,
                      seq.frame(idx[k]).timestamp + options.time_offset, options.sensor_label);
    if (progress) progress(k + 1, idx.size());
  }
  writer.close();
  return idx.size();
}

}  // namespace obm::io
