#pragma once
// Test-only helpers: a minimal KITTI pose-file reader and trajectory perturbations.
#include <gtest/gtest.h>

#include <array>
#include <fstream>
#include <sstream>
#include <string>

#include "obm/core/se3.hpp"
#include "obm/eval/kitti_odometry.hpp"
#include "test_data.hpp"

namespace obm::test {

/// Reads a KITTI odometry pose file: one row-major 3×4 [R|t] per line (12 numbers). The rotations
/// are projected onto SO(3): the file's 7 significant digits leave R·Rᵀ − I at ~1e-6, which the
/// perturbation integrators below would otherwise accumulate into ~1e-4 relative errors.
inline eval::PoseList readKittiPoses(const std::string& path) {
  std::ifstream in(path);
  eval::PoseList poses;
  if (!in) {
    ADD_FAILURE() << "cannot open " << path;
    return poses;
  }
  std::string line;
  std::size_t line_no = 0;
  while (std::getline(in, line)) {
    ++line_no;
    if (line.find_first_not_of(" \t\r") == std::string::npos) continue;
    std::istringstream ss(line);
    std::array<double, 12> v{};
    for (double& x : v)
      if (!(ss >> x)) {
        ADD_FAILURE() << path << ":" << line_no << ": expected 12 numbers";
        return poses;
      }
    Isometry3d T = fromRowMajor3x4(v);
    T.linear() = orthonormalize(T.linear());
    poses.push_back(T);
  }
  return poses;
}

/// Ground truth of KITTI odometry sequence 00 (4541 poses) from the shared reference data.
inline std::string kitti00PosesPath() {
  return sharedDataDir() + "/kitti/poses/00.txt";
}

/// A straight trajectory along the camera's forward axis z with `step` metres per frame.
inline eval::PoseList straightLine(std::size_t n, double step) {
  eval::PoseList poses;
  for (std::size_t i = 0; i < n; ++i) {
    Isometry3d T = Isometry3d::Identity();
    T.translation() = Eigen::Vector3d(0.0, 0.0, step * static_cast<double>(i));
    poses.push_back(T);
  }
  return poses;
}

/// Re-integrates the relative motions of `gt` with every translation increment multiplied by
/// `scale` (a constant odometry scale drift). Rotations are unchanged, and
/// Δpred(i→j) = (R_Δgt, scale · t_Δgt) exactly for every pair i < j.
inline eval::PoseList scaleDrift(const eval::PoseList& gt, double scale) {
  eval::PoseList out{gt.front()};
  for (std::size_t i = 1; i < gt.size(); ++i) {
    Isometry3d rel = relative(gt[i - 1], gt[i]);
    rel.translation() *= scale;
    out.push_back(out.back() * rel);
  }
  return out;
}

/// Applies a world-frame rotation that grows by `rate_rad` per frame about `axis`:
/// pred_i = Rot(axis, rate·i) · gt_i. The residual motion of any pair (i, j) then rotates by
/// exactly rate·(j − i).
inline eval::PoseList worldYawDrift(const eval::PoseList& gt, double rate_rad,
                                    const Eigen::Vector3d& axis) {
  eval::PoseList out;
  for (std::size_t i = 0; i < gt.size(); ++i) {
    Isometry3d W = Isometry3d::Identity();
    W.linear() = Eigen::AngleAxisd(rate_rad * static_cast<double>(i), axis).toRotationMatrix();
    out.push_back(W * gt[i]);
  }
  return out;
}

}  // namespace obm::test
