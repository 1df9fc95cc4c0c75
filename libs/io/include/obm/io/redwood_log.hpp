#pragma once
/// \file redwood_log.hpp
/// The Redwood / 3DMatch `.log` and `.info` files (Choi, Zhou, Koltun, "Robust Reconstruction of
/// Indoor Scenes", CVPR 2015; format page redwood-data.org/indoor/fileformat.html):
///  - `.log`: items of 5 lines, a metadata line of three integers then a 4×4 homogeneous matrix;
///    in a camera trajectory the metadata is `k k k+1` and the matrix is camera-to-world,
///    T_world_camera (p_world = T · p_camera); in a registration file (`gt.log`, results) the
///    metadata is `i j n_fragments` and the matrix aligns fragment j to fragment i, T_i_j
///    (p_i = T · p_j);
///  - `.info`: items of 7 lines, the same metadata then a 6×6 information matrix (ordered
///    translation, rotation as in the benchmark's error metric).
#include <Eigen/Core>
#include <string>
#include <vector>

#include "obm/core/se3.hpp"

namespace obm::io {

/// One item of a `.log` file: metadata and matrix, as stored.
struct RedwoodLogEntry {
  int i = 0;  ///< first metadata number (frame / fragment id)
  int j = 0;  ///< second metadata number (frame / fragment id)
  int n = 0;  ///< third metadata number (frame number + 1, or number of fragments)
  Isometry3d T = Isometry3d::Identity();  ///< the 4×4 matrix
};

/// Reads a `.log` file. Throws IoError when it cannot be opened and FormatError(file, line) for a
/// metadata line that is not three integers, a matrix row that is not four finite numbers, a last
/// row other than (0 0 0 1) (tolerance 1e-6), or a truncated item.
std::vector<RedwoodLogEntry> readRedwoodLog(const std::string& path);

/// Writes a `.log` file atomically at full precision.
void writeRedwoodLog(const std::string& path, const std::vector<RedwoodLogEntry>& entries);

/// Reads a camera trajectory `.log`: T_world_camera of every item, in file order.
std::vector<Isometry3d> readRedwoodTrajectory(const std::string& path);

/// Writes a camera trajectory `.log` with metadata `k k k+1`.
void writeRedwoodTrajectory(const std::string& path, const std::vector<Isometry3d>& T_world_camera);

/// One fragment pair of a registration `.log` (3DMatch / Redwood `gt.log`).
struct FragmentPair {
  int id1 = 0;                                    ///< target fragment i
  int id2 = 0;                                    ///< source fragment j
  int num_fragments = 0;                          ///< fragments in the scene
  Isometry3d T_id1_id2 = Isometry3d::Identity();  ///< aligns id2 to id1: p_id1 = T · p_id2
};

/// Reads a registration `.log` (`gt.log`); errors as readRedwoodLog().
std::vector<FragmentPair> readFragmentPairs(const std::string& path);

/// Writes a registration `.log` atomically.
void writeFragmentPairs(const std::string& path, const std::vector<FragmentPair>& pairs);

/// One item of a `.info` file.
struct RedwoodInfoEntry {
  int i = 0, j = 0, n = 0;  ///< metadata, as in the matching `.log`
  Eigen::Matrix<double, 6, 6> information = Eigen::Matrix<double, 6, 6>::Identity();
};

/// Reads a `.info` file (7 lines per item); errors as readRedwoodLog().
std::vector<RedwoodInfoEntry> readRedwoodInfo(const std::string& path);

/// Writes a `.info` file atomically.
void writeRedwoodInfo(const std::string& path, const std::vector<RedwoodInfoEntry>& entries);

}  // namespace obm::io
