#pragma once
/// \file kitti.hpp
/// KITTI odometry benchmark files (Geiger et al., "Are we ready for autonomous driving?", CVPR
/// 2012, and the odometry devkit's readme):
///  - `velodyne/NNNNNN.bin`: float32 little-endian records `x y z reflectance`, 16 bytes per point,
///    x forward, y left, z up [m], reflectance in [0, 1];
///  - `poses/NN.txt`: per line the row-major 3×4 `[R|t]` of T_world_cam0, the left grey camera
///    (x right, y down, z forward) in the frame of the first camera pose;
///  - `times.txt`: one time stamp [s] per scan, relative to the sequence start;
///  - `calib.txt`: lines `KEY: v1 … v12`; `P0` is the rectified 3×4 projection of camera 0 and
///    `Tr` the velodyne→camera-0 extrinsic, T_cam0_velo (p_cam0 = Tr · p_velo).
///
/// LiDAR poses follow from camera poses as T_world_velo = Tr⁻¹ · T_world_cam0 · Tr, where "world"
/// is the LiDAR frame at the first scan (the ground truth starts at the identity).
#include <Eigen/Core>
#include <cstddef>
#include <string>
#include <vector>

#include "obm/core/point_cloud.hpp"
#include "obm/core/se3.hpp"
#include "obm/io/trajectory.hpp"

namespace obm::io {

/// What a velodyne `.bin` read found besides the kept points.
struct KittiScanStats {
  std::size_t num_records = 0;     ///< points stored in the file
  std::size_t num_non_finite = 0;  ///< records with a NaN / infinite value, dropped
};

/// Reads a KITTI velodyne scan (frame_id "velodyne", intensity = reflectance, timestamp 0).
/// Records with a non-finite coordinate or reflectance are dropped and counted in `stats`.
/// Throws IoError when the file cannot be read and FormatError naming the file when its size is not
/// a multiple of 16 bytes.
PointCloud readKittiVelodyne(const std::string& path, KittiScanStats* stats = nullptr);

/// Writes a cloud as a KITTI velodyne scan, atomically (reflectance 0 when the cloud has no
/// intensity). Throws ContractError for a cloud with mis-sized attributes, IoError on failure.
void writeKittiVelodyne(const std::string& path, const PointCloud& cloud);

/// The devkit's scan file name of frame `index`: six digits + ".bin" ("000042.bin").
std::string kittiScanFileName(std::size_t index);

/// Reads `poses/NN.txt` (T_world_cam0 per line); see readKittiTrajectory() for the errors.
inline std::vector<Isometry3d> readKittiPoses(const std::string& path) {
  return readKittiTrajectory(path);
}

/// Writes poses in the KITTI layout; see writeKittiTrajectory().
inline void writeKittiPoses(const std::string& path, const std::vector<Isometry3d>& poses) {
  writeKittiTrajectory(path, poses);
}

/// Reads `times.txt`: one finite number [s] per line (blank lines skipped). Throws IoError /
/// FormatError(file, line).
std::vector<double> readKittiTimes(const std::string& path);

/// Writes one time stamp per line, atomically, at full precision.
void writeKittiTimes(const std::string& path, const std::vector<double>& times);

/// The parts of `calib.txt` the project uses.
struct KittiCalib {
  /// Rectified projection matrix of camera 0 (`P0`), [px]; zero when the file has no `P0`.
  Eigen::Matrix<double, 3, 4> P0 = Eigen::Matrix<double, 3, 4>::Zero();
  bool has_P0 = false;  ///< whether `P0` was present
  /// `Tr`: velodyne → camera 0, p_cam0 = T_cam0_velo · p_velo.
  Isometry3d T_cam0_velo = Isometry3d::Identity();
};

/// Reads `calib.txt`: requires a `Tr:` line (or `Tr_velo_to_cam:`, its name in KITTI's object
/// benchmark), reads `P0:` when present, ignores other keys. Throws IoError / FormatError(file,
/// line) for a line that is not `KEY: 12 numbers`, and FormatError(file) when `Tr` is missing.
KittiCalib readKittiCalib(const std::string& path);

/// Writes `P0:` (when has_P0) and `Tr:` lines, atomically, at full precision.
void writeKittiCalib(const std::string& path, const KittiCalib& calib);

/// T_world_velo = Tr⁻¹ · T_world_cam0 · Tr, with Tr = T_cam0_velo.
Isometry3d cameraToLidarPose(const Isometry3d& T_world_cam0, const Isometry3d& T_cam0_velo);

/// The inverse of cameraToLidarPose(): T_world_cam0 = Tr · T_world_velo · Tr⁻¹.
Isometry3d lidarToCameraPose(const Isometry3d& T_world_velo, const Isometry3d& T_cam0_velo);

/// cameraToLidarPose() on every pose.
std::vector<Isometry3d> cameraToLidarPoses(const std::vector<Isometry3d>& T_world_cam0,
                                           const Isometry3d& T_cam0_velo);

/// lidarToCameraPose() on every pose.
std::vector<Isometry3d> lidarToCameraPoses(const std::vector<Isometry3d>& T_world_velo,
                                           const Isometry3d& T_cam0_velo);

/// A KITTI odometry sequence folder (`<root>/sequences/NN/` in the devkit layout) holding
/// `velodyne/*.bin`, `times.txt` and `calib.txt`, with optional ground truth.
///
/// Ground truth is looked up, first found wins: the `poses_path` given to the constructor,
/// `<dir>/poses.txt`, then the devkit's `<dir>/../../poses/<NN>.txt`. Its poses are in the camera-0
/// frame in the file and are offered in the LiDAR frame too.
class KittiSequence {
 public:
  /// Opens and checks the folder: scan files are `velodyne/*.bin` in name order; the number of
  /// time stamps and of ground-truth poses must equal the number of scans. Throws IoError for a
  /// missing folder or file and FormatError naming the file for inconsistent content.
  explicit KittiSequence(const std::string& dir, const std::string& poses_path = "");

  /// Number of scans.
  std::size_t size() const noexcept { return scan_paths_.size(); }

  /// Scan `i` (frame_id "velodyne", timestamp = times.txt entry); ContractError when out of range.
  PointCloud scan(std::size_t i, KittiScanStats* stats = nullptr) const;

  /// Path of scan `i`.
  const std::string& scanPath(std::size_t i) const;

  /// [s] time stamp of scan `i` (from times.txt).
  double timestamp(std::size_t i) const;
  const std::vector<double>& timestamps() const noexcept { return times_; }

  const KittiCalib& calib() const noexcept { return calib_; }

  /// Whether ground truth was found.
  bool hasGroundTruth() const noexcept { return !gt_cam_.empty(); }
  /// The ground-truth file read ("" when none).
  const std::string& groundTruthPath() const noexcept { return gt_path_; }
  /// Ground truth as in the file: T_world_cam0 per scan (empty when none).
  const std::vector<Isometry3d>& groundTruthCamera() const noexcept { return gt_cam_; }
  /// Ground truth of the LiDAR: T_world_velo per scan, world = first LiDAR frame (empty when none).
  const std::vector<Isometry3d>& groundTruthLidar() const noexcept { return gt_velo_; }
  /// groundTruthLidar() with the scans' time stamps.
  Trajectory groundTruthLidarStamped() const;

  /// The folder given to the constructor.
  const std::string& directory() const noexcept { return dir_; }
  /// The folder's name ("00" for `sequences/00`).
  std::string name() const;

 private:
  std::string dir_;
  std::vector<std::string> scan_paths_;
  std::vector<double> times_;
  KittiCalib calib_;
  std::string gt_path_;
  std::vector<Isometry3d> gt_cam_;
  std::vector<Isometry3d> gt_velo_;
};

}  // namespace obm::io
