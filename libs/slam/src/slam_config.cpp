#include "obm/slam/slam_config.hpp"

#include <cmath>

#include "obm/config/config_node.hpp"
#include "obm/core/errors.hpp"

namespace obm::slam {

namespace {
void require(bool ok, const std::string& key, const std::string& what) {
  if (!ok) throw ConfigError(key + ": " + what);
}
template <typename F>
void validateAt(const ConfigNode& node, F&& validate) {
  try {
    validate();
  } catch (const ConfigError& e) {
    throw ConfigError(node.where() + ": " + e.what());
  }
}
}  // namespace

void InputParams::validate() const {
  require(rgbd_stride >= 1, "rgbd_stride", "must be >= 1");
  require(std::isfinite(rgbd_edge_jump) && rgbd_edge_jump >= 0.0, "rgbd_edge_jump",
          "must be >= 0 (a fraction of the depth; 0 = off)");
  require(std::isfinite(depth_min) && depth_min >= 0.0, "depth_min", "must be >= 0 [m]");
  require(std::isfinite(depth_max) && depth_max >= 0.0, "depth_max", "must be >= 0 [m] (0 = all)");
  require(depth_max == 0.0 || depth_max > depth_min, "depth_max", "must exceed depth_min");
  require(std::isfinite(max_time_difference) && max_time_difference > 0.0, "max_time_difference",
          "must be > 0 [s]");
  require(std::isfinite(velodyne_min_range) && velodyne_min_range >= 0.0, "velodyne_min_range",
          "must be >= 0 [m]");
}

InputParams InputParams::load(const ConfigNode& node) {
  node.checkKeys({"rgbd_stride", "rgbd_color", "rgbd_edge_jump", "depth_min", "depth_max", "max_time_difference", "sensor_label",
                  "velodyne_min_range"});
  InputParams p;
  node.get("rgbd_stride", p.rgbd_stride);
  node.get("rgbd_color", p.rgbd_color);
  node.get("rgbd_edge_jump", p.rgbd_edge_jump);
  node.get("depth_min", p.depth_min);
  node.get("depth_max", p.depth_max);
  node.get("max_time_difference", p.max_time_difference);
  node.get("sensor_label", p.sensor_label);
  node.get("velodyne_min_range", p.velodyne_min_range);
  validateAt(node, [&] { p.validate(); });
  return p;
}

void OutputParams::validate() const {
  require(map_every >= 1, "map_every", "must be >= 1");
  require(std::isfinite(map_cloud_voxel) && map_cloud_voxel >= 0.0, "map_cloud_voxel",
          "must be >= 0 [m]");
  require(std::isfinite(map_rebuild_translation) && map_rebuild_translation >= 0.0,
          "map_rebuild_translation", "must be >= 0 [m]");
  require(std::isfinite(map_rebuild_rotation) && map_rebuild_rotation >= 0.0,
          "map_rebuild_rotation_deg", "must be >= 0 [deg]");
  require(png_max_pixels >= 64, "png_max_pixels", "must be >= 64");
  require(std::isfinite(scene_voxel) && scene_voxel > 0.0, "scene_voxel", "must be > 0 [m]");
  require(std::isfinite(autosave_s) && autosave_s >= 0.0, "autosave_s", "must be >= 0 [s]");
}

OutputParams OutputParams::load(const ConfigNode& node) {
  node.checkKeys({"map", "pictures", "map_every", "map_cloud_voxel", "map_rebuild_translation",
                  "map_rebuild_rotation_deg", "png_z_max", "png_max_pixels", "mrpt",
                  "scene_voxel", "autosave_s"});
  OutputParams p;
  node.get("autosave_s", p.autosave_s);
  node.get("map", p.map);
  node.get("mrpt", p.mrpt);
  node.get("scene_voxel", p.scene_voxel);
  node.get("pictures", p.pictures);
  node.get("map_every", p.map_every);
  node.get("map_cloud_voxel", p.map_cloud_voxel);
  node.get("map_rebuild_translation", p.map_rebuild_translation);
  node.getDegAsRad("map_rebuild_rotation_deg", p.map_rebuild_rotation);
  node.get("png_z_max", p.png_z_max);
  node.get("png_max_pixels", p.png_max_pixels);
  validateAt(node, [&] { p.validate(); });
  return p;
}

SlamConfig SlamConfig::load(const ConfigNode& root) {
  std::vector<std::string> known = frontend::FrontendParams::sections();
  known.insert(known.end(), {"mapping", "input", "output"});
  root.checkKeys(known);
  SlamConfig c;
  c.frontend = frontend::FrontendParams::load(root);
  c.mapping = mapping::MappingParams::load(root.child("mapping"));
  c.input = InputParams::load(root.child("input"));
  c.output = OutputParams::load(root.child("output"));
  c.source = root.file();
  return c;
}

SlamConfig SlamConfig::loadFile(const std::string& path) {
  return load(ConfigNode::loadFile(path));
}

}  // namespace obm::slam
