#pragma once
/// \file peers.hpp
/// Registration methods compared by obm-bench. Each is a function (source, target) →
/// T_target_source; the classical peers of Open3D (ICP, FGR, RANSAC + FPFH) are compiled in only
/// when Open3D is found.
#include <functional>
#include <string>
#include <utility>
#include <vector>

#include "obm/core/point_cloud.hpp"
#include "obm/core/se3.hpp"

namespace obm::bench {

/// What a method returns: its pose and, optionally, named confidence scores of the pair (higher =
/// more likely correct) that obm-bench rates by AUROC against the pairs' correctness.
struct MethodResult {
  Isometry3d T_target_source = Isometry3d::Identity();
  std::vector<std::pair<std::string, double>> scores;
  MethodResult() = default;
  MethodResult(const Isometry3d& T) : T_target_source(T) {}  // NOLINT: a bare pose converts
};

using RegisterFn =
    std::function<MethodResult(const PointCloud& source, const PointCloud& target)>;

struct Method {
  std::string name;
  RegisterFn fn;
  /// A diagnostic, not a registration: the method is given the source already moved by the
  /// pair's ground truth and its pose is composed with it (`icp@truth`: how far the refinement
  /// leaves the answer when started at it).
  bool start_at_truth = false;
};

/// Parameters of the Open3D peers, in the units of the clouds (unit sphere for objects).
struct Open3dParams {
  double voxel = 0.05;            ///< down-sampling before features
  double normal_radius = 0.1;     ///< normals (point-to-plane ICP, FPFH)
  double feature_radius = 0.25;   ///< FPFH
  double icp_max_distance = 0.1;  ///< ICP correspondence distance
  double ransac_max_distance = 0.075;
  int ransac_iterations = 100000;
  double ransac_confidence = 0.999;
  /// Add Open3D's coloured ICP rows (`o3d_cicp`, `o3d_fgr+cicp`): set when every pair's clouds
  /// carry colours (RGB-D frames).
  bool colored = false;
};

/// Whether this build has the Open3D peers.
bool haveOpen3d();

/// The names of every Open3D peer (the coloured ones included), built with Open3D or not, so that
/// a request for one is recognised and, without Open3D, reported unavailable.
std::vector<std::string> open3dMethodNames();

/// Open3D's point-to-plane ICP from identity, FGR (FPFH), RANSAC (FPFH), and FGR followed by ICP;
/// with `colored`, also Open3D's coloured ICP (Park, Zhou & Koltun 2017) from the identity and
/// after FGR, coarse to fine over four gates (icp_max_distance, then 0.4, 0.2 and 0.1 of it, each
/// on its own voxel grid, as in Open3D's own coloured-ICP recipe). Empty when Open3D is not
/// available.
std::vector<Method> open3dMethods(const Open3dParams& params);

}  // namespace obm::bench
