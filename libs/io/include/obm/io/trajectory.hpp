#pragma once
/// \file trajectory.hpp
/// Trajectory files: the TUM RGB-D format (`timestamp tx ty tz qx qy qz qw`, as the TUM benchmark
/// tools and evo read it) and the KITTI odometry format (12 numbers of a row-major 3×4 `[R|t]` per
/// line, no timestamps), plus the nearest-timestamp association of two stamped sequences with the
/// semantics of the TUM benchmark's `associate.py`.
///
/// Every pose is `T_world_body` (p_world = T · p_body). Writers keep full double precision (each
/// number is written as the shortest text that reads back to the same double) and are atomic.
#include <cstddef>
#include <string>
#include <vector>

#include "obm/core/se3.hpp"

namespace obm::io {

/// A pose with its time stamp.
struct StampedPose {
  double t = 0.0;                         ///< [s] time stamp (UNIX time or sequence time)
  Isometry3d T = Isometry3d::Identity();  ///< T_world_body
};

/// A time-ordered (by convention, not enforced) list of stamped poses.
using Trajectory = std::vector<StampedPose>;

/// Reads a TUM trajectory: one pose per line, `timestamp tx ty tz qx qy qz qw` separated by
/// spaces, tabs or commas; lines starting with `#` and blank lines are skipped. The quaternion is
/// normalised. Throws IoError when the file cannot be opened and FormatError(file, line) for a
/// line without exactly 8 numbers, a non-finite value or a zero quaternion.
Trajectory readTumTrajectory(const std::string& path);

/// Writes a TUM trajectory (header comment + one line per pose, quaternion with qw ≥ 0),
/// atomically. Throws IoError on failure.
void writeTumTrajectory(const std::string& path, const Trajectory& trajectory);

/// Reads a KITTI-format trajectory: 12 numbers per line, the row-major 3×4 matrix `[R|t]` of
/// T_world_body. Blank lines are skipped. Throws IoError / FormatError(file, line) for a line
/// that does not hold exactly 12 finite numbers.
std::vector<Isometry3d> readKittiTrajectory(const std::string& path);

/// Writes a KITTI-format trajectory atomically (12 numbers per line, exact round trip).
void writeKittiTrajectory(const std::string& path, const std::vector<Isometry3d>& poses);

/// The poses of a trajectory, without time stamps.
std::vector<Isometry3d> posesOf(const Trajectory& trajectory);

/// The time stamps of a trajectory.
std::vector<double> timestampsOf(const Trajectory& trajectory);

/// Pairs poses with time stamps; throws ContractError when the sizes differ.
Trajectory stampPoses(const std::vector<Isometry3d>& poses, const std::vector<double>& times);

/// One match of an association: indices into the first and second sequence.
struct TimestampMatch {
  std::size_t first = 0;    ///< index into the first sequence
  std::size_t second = 0;   ///< index into the second sequence
  double difference = 0.0;  ///< [s] |t_first − (t_second + offset)|
};

/// Associates two time-stamp sequences like the TUM benchmark's `associate.py`: every pair with
/// |a − (b + offset)| < max_difference is a candidate; candidates are accepted greedily in order of
/// increasing difference, each element being used at most once; the result is sorted by the first
/// sequence's time stamp. Neither input needs to be sorted. O((n + m) log + candidates).
/// \param max_difference [s] strict upper bound on the difference (associate.py default 0.02)
/// \param offset [s] added to the second sequence's time stamps
std::vector<TimestampMatch> associateTimestamps(const std::vector<double>& first,
                                                const std::vector<double>& second,
                                                double max_difference = 0.02, double offset = 0.0);

/// associateTimestamps() on the time stamps of two trajectories.
std::vector<TimestampMatch> associate(const Trajectory& first, const Trajectory& second,
                                      double max_difference = 0.02, double offset = 0.0);

}  // namespace obm::io
