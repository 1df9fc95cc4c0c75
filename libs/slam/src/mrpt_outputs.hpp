#pragma once
// The files of an obm-map run that MRPT's own tools open (docs/obm-map.md, "MRPT tools").
#include <functional>
#include <string>
#include <vector>

#include "obm/core/se3.hpp"
#include "obm/frontend/frontend.hpp"

namespace obm::slam {

/// Writes keyframes.simplemap, scene.3Dscene and trajectory_mrpt.txt; `file(name)` gives the
/// path of an output (and records it). `gt` is the ground truth in the estimate's world frame
/// (empty when none); the scene is drawn in the gravity-up frame T_up_sensor · T_world_sensor.
void writeMrptOutputs(const frontend::Frontend& fe, const std::vector<Isometry3d>& traj,
                      const std::vector<double>& stamps, const std::vector<Isometry3d>& gt,
                      const Isometry3d& T_up_sensor, double scene_voxel,
                      const std::function<std::string(const std::string&)>& file);

}  // namespace obm::slam
