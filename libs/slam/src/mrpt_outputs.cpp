#include "mrpt_outputs.hpp"

#include <map>

#include "obm/backend/pose_graph.hpp"
#include "obm/core/cloud_ops.hpp"
#include "obm/mrpt_bridge/export.hpp"
#include "obm/registration/match_result.hpp"

namespace obm::slam {

void writeMrptOutputs(const frontend::Frontend& fe, const std::vector<Isometry3d>& traj,
                      const std::vector<double>& stamps, const std::vector<Isometry3d>& gt,
                      const Isometry3d& T_up_sensor, double scene_voxel,
                      const std::function<std::string(const std::string&)>& file) {
  const auto& kfs = fe.keyframes();
  // The covariance of each keyframe: that of the registration that placed it, relative to the
  // previous keyframe (the odometry edge's information, bias-weighted for the OBMNet matchers).
  // Keyframe 0 anchors the map (covariance ~0). It is not the marginal of the optimised graph.
  std::map<std::size_t, Matrix6d> info_of;
  const backend::PoseGraph graph = fe.graph();
  for (const auto& e : graph.edges3)
    if (!e.is_loop && e.to == e.from + 1)
      info_of[e.to] = registration::informationG2oToTheta(e.information);
  std::vector<mrpt_bridge::ExportKeyframe> out;
  out.reserve(kfs.size());
  for (const auto& kf : kfs) {
    mrpt_bridge::ExportKeyframe e;
    e.timestamp = kf.timestamp;
    e.T_world_sensor = kf.T_world_sensor;
    e.cloud = kf.cloud;
    const auto it = info_of.find(kf.id);
    e.information = kf.id == 0 ? Matrix6d(1e12 * Matrix6d::Identity())
                               : (it != info_of.end() ? it->second : Matrix6d::Zero());
    out.push_back(std::move(e));
  }
  mrpt_bridge::writeSimpleMap(file("keyframes.simplemap"), out);
  mrpt_bridge::writePoseInterpolatorText(file("trajectory_mrpt.txt"), stamps, traj);

  mrpt_bridge::SceneContent scene;
  for (const auto& T : traj) scene.trajectory.push_back(T_up_sensor * T);
  for (const auto& T : gt) scene.ground_truth.push_back(T_up_sensor * T);
  PointCloud merged;
  for (const auto& kf : kfs) {
    const Isometry3d T = T_up_sensor * kf.T_world_sensor;
    scene.keyframes.push_back(T);
    for (const auto& p : kf.cloud.points) merged.points.push_back((T * p.cast<double>()).cast<float>());
  }
  scene.map_points = voxelDownsample(merged, scene_voxel);
  for (const auto& lc : fe.loops())
    if (lc.accepted && lc.from < kfs.size() && lc.to < kfs.size())
      scene.loops.emplace_back((T_up_sensor * kfs[lc.from].T_world_sensor).translation(),
                               (T_up_sensor * kfs[lc.to].T_world_sensor).translation());
  mrpt_bridge::write3DScene(file("scene.3Dscene"), scene);
}

}  // namespace obm::slam
