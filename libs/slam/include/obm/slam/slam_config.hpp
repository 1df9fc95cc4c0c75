#pragma once
/// \file slam_config.hpp
/// The configuration of the mapping app (config/map_kitti.yaml, config/map_indoor.yaml): the
/// front-end's sections (obm::frontend::FrontendParams), the OctoMap's (`mapping:`,
/// obm::mapping::MappingParams), and the app's own `input:` and `output:` sections below. Each
/// struct is loaded in one place; unknown sections and keys throw ConfigError naming file and key.
#include <cstddef>
#include <string>

#include "obm/frontend/params.hpp"
#include "obm/mapping/mapping_params.hpp"

namespace obm {
class ConfigNode;
}

namespace obm::slam {

/// How frames are read (YAML `input:`).
struct InputParams {
  /// RGB-D folders: every n-th pixel row and column is back-projected (>= 1).
  int rgbd_stride = 2;
  /// RGB-D folders: attach each frame's colour image (PNG or JPEG, registered to the depth) to its
  /// points, for coloured ICP (tracking.icp.color_weight). A frame whose colour cannot be read is
  /// used without colour (warning).
  bool rgbd_color = false;
  /// RGB-D folders: drop depth pixels on discontinuities, where a neighbour's depth differs by
  /// more than this fraction of the depth (flying pixels between two surfaces); 0 = keep all.
  double rgbd_edge_jump = 0.0;
  double depth_min = 0.0;  ///< [m] RGB-D: nearer depth is dropped
  double depth_max = 0.0;  ///< [m] RGB-D: farther depth is dropped; 0 = keep all
  /// [s] strict bound on |t_frame − t_ground_truth| when a TUM-format ground truth is associated
  /// with the frames by time stamp (TUM associate.py's default 0.02 s).
  double max_time_difference = 0.02;
  /// Rawlogs: only observations with this sensor label ("" = every observation with points).
  std::string sensor_label;
  double velodyne_min_range = 1.0;  ///< [m] rawlog Velodyne scans: ranges kept (MRPT's default)

  static InputParams load(const ConfigNode& node);
  void validate() const;
};

/// What is written besides the trajectories, graph and reports (YAML `output:`).
struct OutputParams {
  bool map = true;       ///< build the OctoMap (map.bt, map.ot, map_topview.png)
  bool pictures = true;  ///< trajectory_topview.png (and map_topview.png when `map`)
  /// Integrate every n-th keyframe into the OctoMap (>= 1).
  std::size_t map_every = 1;
  /// [m] keyframe clouds are kept for the map voxelised at this size in the sensor frame;
  /// 0 = half the map resolution.
  double map_cloud_voxel = 0.0;
  /// Keyframes go into the OctoMap (in a worker thread) as soon as they are made; if the final
  /// optimisation then moved any of them by more than these, the map is rebuilt at the final poses.
  double map_rebuild_translation = 0.1;           ///< [m]
  double map_rebuild_rotation = 0.1 * kDegToRad;  ///< [rad] (YAML `_deg`)
  /// Top view: ignore voxels above this height in the map frame [m] (ceilings); none by default.
  double png_z_max = 1e30;
  int png_max_pixels = 2048;  ///< [px] largest side of the pictures
  /// Files for MRPT's tools: keyframes.simplemap (observations2map, CSimpleMap consumers),
  /// scene.3Dscene (SceneViewer3D) and trajectory_mrpt.txt (CPose3DInterpolator text).
  bool mrpt = true;
  /// [m] voxel of the map points drawn in scene.3Dscene (the keyframe clouds, merged).
  double scene_voxel = 0.5;
  /// [s] while the run goes on, trajectory_tum.txt and trajectory_kitti.txt are rewritten
  /// (atomically) with every frame so far at this interval, so that a run killed without a chance
  /// to write (SIGKILL, out of memory, power) keeps its poses up to the last save; 0 = off.
  double autosave_s = 60.0;

  static OutputParams load(const ConfigNode& node);
  void validate() const;
};

/// The whole configuration of obm-map.
struct SlamConfig {
  frontend::FrontendParams frontend;
  mapping::MappingParams mapping;
  InputParams input;
  OutputParams output;
  std::string source;  ///< file it was read from ("" = defaults / string)

  /// Reads the root map: the front-end's sections plus `mapping`, `input`, `output`.
  static SlamConfig load(const ConfigNode& root);
  /// Loads a YAML file (IoError when missing, ConfigError naming file and key otherwise).
  static SlamConfig loadFile(const std::string& path);
};

}  // namespace obm::slam
