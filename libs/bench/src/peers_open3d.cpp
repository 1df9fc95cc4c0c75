// The classical peers of obm-bench, run in-process through Open3D 0.16 (Debian libopen3d-dev).
#include "obm/bench/peers.hpp"

#include "obm/core/errors.hpp"

#ifdef OBM_HAVE_OPEN3D
#include <open3d/geometry/KDTreeSearchParam.h>
#include <open3d/geometry/PointCloud.h>
#include <open3d/pipelines/registration/ColoredICP.h>
#include <open3d/pipelines/registration/FastGlobalRegistration.h>
#include <open3d/pipelines/registration/Feature.h>
#include <open3d/pipelines/registration/Registration.h>
#include <open3d/utility/Logging.h>
#include <open3d/utility/Random.h>

#include <cstdint>
#include <cstring>
#endif

namespace obm::bench {

std::vector<std::string> open3dMethodNames() {
  return {"o3d_icp", "o3d_fgr", "o3d_fgr+icp", "o3d_fgr+icp_p2p", "o3d_ransac", "o3d_cicp",
          "o3d_fgr+cicp"};
}

#ifdef OBM_HAVE_OPEN3D
namespace reg = open3d::pipelines::registration;

namespace {

struct Prepared {
  std::shared_ptr<open3d::geometry::PointCloud> full, down;
  std::shared_ptr<reg::Feature> fpfh;
};

Prepared prepare(const PointCloud& c, const Open3dParams& p, bool features) {
  Prepared out;
  out.full = std::make_shared<open3d::geometry::PointCloud>();
  out.full->points_.reserve(c.size());
  for (const auto& q : c.points) out.full->points_.push_back(q.cast<double>());
  if (p.colored && c.hasColors()) {
    out.full->colors_.reserve(c.size());
    for (const auto& rgb : c.colors) out.full->colors_.push_back(rgb.cast<double>() / 255.0);
  }
  out.full->EstimateNormals(open3d::geometry::KDTreeSearchParamHybrid(p.normal_radius, 30));
  if (features) {
    out.down = out.full->VoxelDownSample(p.voxel);
    out.down->EstimateNormals(open3d::geometry::KDTreeSearchParamHybrid(p.normal_radius, 30));
    out.fpfh = reg::ComputeFPFHFeature(
        *out.down, open3d::geometry::KDTreeSearchParamHybrid(p.feature_radius, 100));
  }
  return out;
}

Isometry3d toIso(const Eigen::Matrix4d& M) {
  Isometry3d T = Isometry3d::Identity();
  T.matrix() = M;
  return T;
}

/// Open3D ICP on the full clouds: point-to-plane, or Open3D's default point-to-point (whose
/// minimum is unbiased when both clouds jitter the same samples, see IcpParams in the project).
Eigen::Matrix4d icp(const Prepared& s, const Prepared& t, const Eigen::Matrix4d& init,
                    const Open3dParams& p, bool point_to_plane = true) {
  const reg::ICPConvergenceCriteria stop(1e-7, 1e-7, 60);
  if (!point_to_plane)
    return reg::RegistrationICP(*s.full, *t.full, p.icp_max_distance, init,
                                reg::TransformationEstimationPointToPoint(false), stop)
        .transformation_;
  return reg::RegistrationICP(*s.full, *t.full, p.icp_max_distance, init,
                              reg::TransformationEstimationPointToPlane(), stop)
      .transformation_;
}

/// Open3D's coloured ICP, coarse to fine: at each gate r both clouds on an r voxel grid with
/// normals from radius 2r, at most 50, 50, 30, 14 iterations (Open3D's recipe, with the
/// point-to-plane ICP's gate as a first, wider stage).
Eigen::Matrix4d coloredIcp(const Prepared& s, const Prepared& t, const Eigen::Matrix4d& init,
                           const Open3dParams& p) {
  if (!s.full->HasColors() || !t.full->HasColors())
    throw Error("o3d_cicp: a cloud of the pair has no colours");
  const double gates[] = {p.icp_max_distance, 0.4 * p.icp_max_distance,
                          0.2 * p.icp_max_distance, 0.1 * p.icp_max_distance};
  const int iterations[] = {50, 50, 30, 14};
  Eigen::Matrix4d T = init;
  for (int k = 0; k < 4; ++k) {
    const double r = gates[k];
    auto sd = s.full->VoxelDownSample(r), td = t.full->VoxelDownSample(r);
    sd->EstimateNormals(open3d::geometry::KDTreeSearchParamHybrid(2.0 * r, 30));
    td->EstimateNormals(open3d::geometry::KDTreeSearchParamHybrid(2.0 * r, 30));
    if (sd->points_.size() < 10 || td->points_.size() < 10) continue;
    T = reg::RegistrationColoredICP(*sd, *td, r, T, reg::TransformationEstimationForColoredICP(),
                                    reg::ICPConvergenceCriteria(1e-6, 1e-6, iterations[k]))
            .transformation_;
  }
  return T;
}

/// Seeds Open3D's random engine from the pair's down-sampled clouds (FNV-1a over their
/// coordinates), so that FGR and RANSAC draw the same samples for a pair in every row that runs
/// them (`o3d_fgr`, `o3d_fgr+icp`, `obmnet+icp@fgr`, …) and in every run: the rows then differ by
/// what follows the feature match, not by its luck.
void seedFromPair(const Prepared& s, const Prepared& t) {
  std::uint64_t h = 1469598103934665603ull;
  for (const auto* c : {s.down.get(), t.down.get()})
    for (const auto& q : c->points_)
      for (int k = 0; k < 3; ++k) {
        std::uint64_t bits = 0;
        std::memcpy(&bits, &q[k], sizeof(bits));
        h = (h ^ bits) * 1099511628211ull;
      }
  open3d::utility::random::Seed(static_cast<int>(h & 0x7fffffff));
}

Eigen::Matrix4d fgr(const Prepared& s, const Prepared& t, const Open3dParams& p) {
  seedFromPair(s, t);
  reg::FastGlobalRegistrationOption o;
  o.maximum_correspondence_distance_ = p.voxel * 0.5;
  return reg::FastGlobalRegistrationBasedOnFeatureMatching(*s.down, *t.down, *s.fpfh, *t.fpfh, o)
      .transformation_;
}

Eigen::Matrix4d ransac(const Prepared& s, const Prepared& t, const Open3dParams& p) {
  seedFromPair(s, t);
  reg::CorrespondenceCheckerBasedOnEdgeLength edge(0.9);
  reg::CorrespondenceCheckerBasedOnDistance dist(p.ransac_max_distance);
  return reg::RegistrationRANSACBasedOnFeatureMatching(
             *s.down, *t.down, *s.fpfh, *t.fpfh, true, p.ransac_max_distance,
             reg::TransformationEstimationPointToPoint(false), 3, {edge, dist},
             reg::RANSACConvergenceCriteria(p.ransac_iterations, p.ransac_confidence))
      .transformation_;
}

}  // namespace

bool haveOpen3d() {
  return true;
}

std::vector<Method> open3dMethods(const Open3dParams& p) {
  open3d::utility::SetVerbosityLevel(open3d::utility::VerbosityLevel::Error);
  std::vector<Method> m;
  m.push_back({"o3d_icp", [p](const PointCloud& s, const PointCloud& t) {
                 return toIso(icp(prepare(s, p, false), prepare(t, p, false),
                                  Eigen::Matrix4d::Identity(), p));
               }});
  m.push_back({"o3d_fgr", [p](const PointCloud& s, const PointCloud& t) {
                 return toIso(fgr(prepare(s, p, true), prepare(t, p, true), p));
               }});
  m.push_back({"o3d_fgr+icp", [p](const PointCloud& s, const PointCloud& t) {
                 const auto S = prepare(s, p, true), T = prepare(t, p, true);
                 return toIso(icp(S, T, fgr(S, T, p), p));
               }});
  m.push_back({"o3d_fgr+icp_p2p", [p](const PointCloud& s, const PointCloud& t) {
                 const auto S = prepare(s, p, true), T = prepare(t, p, true);
                 return toIso(icp(S, T, fgr(S, T, p), p, false));
               }});
  m.push_back({"o3d_ransac", [p](const PointCloud& s, const PointCloud& t) {
                 return toIso(ransac(prepare(s, p, true), prepare(t, p, true), p));
               }});
  if (p.colored) {
    m.push_back({"o3d_cicp", [p](const PointCloud& s, const PointCloud& t) {
                   return toIso(coloredIcp(prepare(s, p, false), prepare(t, p, false),
                                           Eigen::Matrix4d::Identity(), p));
                 }});
    m.push_back({"o3d_fgr+cicp", [p](const PointCloud& s, const PointCloud& t) {
                   const auto S = prepare(s, p, true), T = prepare(t, p, true);
                   return toIso(coloredIcp(S, T, fgr(S, T, p), p));
                 }});
  }
  return m;
}

#else

bool haveOpen3d() {
  return false;
}
std::vector<Method> open3dMethods(const Open3dParams&) {
  return {};
}

#endif

}  // namespace obm::bench
