#pragma once
/// \file scenes.hpp
/// Procedural, seeded scenes — an urban street grid, an urban corridor built around a given
/// trajectory (to drive a real KITTI path through a synthetic city), indoor floors of rooms and
/// corridors, a room furnished around a hand-held trajectory (TUM presets) — and scenes loaded
/// from mesh files. Also the procedural trajectories that go with them: a drive around the blocks
/// that returns to its start, and a hand-held walk through the rooms.
///
/// World frame: x east, y north, z up [m]. Every generator is deterministic for a given seed.
#include <Eigen/Geometry>
#include <array>
#include <cstdint>
#include <string>
#include <vector>

#include "obm/config/config_node.hpp"
#include "obm/sim/geometry.hpp"
#include "obm/sim/trajectory.hpp"

namespace obm::sim {

/// A regular grid of ground heights with bilinear interpolation (clamped at the border).
class HeightMap {
 public:
  HeightMap() = default;
  HeightMap(double x0, double y0, double resolution, int nx, int ny, double fill = 0.0);
  /// Height [m] at (x, y).
  double at(double x, double y) const;
  /// Value of grid node (i, j).
  float& node(int i, int j) { return data_[static_cast<std::size_t>(j) * nx_ + i]; }
  float node(int i, int j) const { return data_[static_cast<std::size_t>(j) * nx_ + i]; }
  double x0() const { return x0_; }
  double y0() const { return y0_; }
  double resolution() const { return res_; }
  int nx() const { return nx_; }
  int ny() const { return ny_; }
  bool empty() const { return data_.empty(); }

 private:
  double x0_ = 0, y0_ = 0, res_ = 1;
  int nx_ = 0, ny_ = 0;
  std::vector<float> data_;
};

/// A generated (or loaded) scene.
struct GeneratedScene {
  SceneMesh mesh;
  /// Region a trajectory must stay in (the modelled part of the world).
  Eigen::AlignedBox3d bounds;
  /// Ground height (road level outdoors, floor indoors).
  HeightMap ground;
  std::string description;  ///< one line, for logs and the README of an output
};

// ---------------------------------------------------------------------------------------------
// Urban

/// Parameters of the urban generator. Lengths in metres.
struct UrbanSceneParams {
  int blocks_x = 3;                ///< drivable blocks east–west (an outer ring is added)
  int blocks_y = 2;                ///< drivable blocks north–south
  double block_length_x = 110.0;   ///< street-centre spacing east–west
  double block_length_y = 90.0;    ///< street-centre spacing north–south
  double street_half_width = 7.0;  ///< centre line to kerb
  double sidewalk_width = 3.5;
  double kerb_height = 0.15;
  int block_types = 3;         ///< distinct block layouts; equal types are identical blocks
  int building_templates = 6;  ///< distinct building styles shared across the city
  int min_floors = 2;
  int max_floors = 6;
  double lot_width_min = 12.0;
  double lot_width_max = 28.0;
  double building_depth_min = 10.0;
  double building_depth_max = 16.0;
  double setback_max = 2.5;          ///< facade distance behind the sidewalk, at most
  double gap_probability = 0.15;     ///< a lot left free (wall, trees) instead of a building
  double car_probability = 0.55;     ///< a parking slot (6 m) is taken
  double tree_spacing = 14.0;        ///< along sidewalks
  double light_spacing = 30.0;       ///< street lights along sidewalks
  double sign_probability = 0.15;    ///< per light position, an extra traffic sign
  double margin = 40.0;              ///< terrain beyond the outermost streets
  double terrain_resolution = 1.25;  ///< ground mesh cell (≤ sidewalk_width / 2.5)
  double slope_x_pct = 0.8;          ///< [%] mean slope east
  double slope_y_pct = 0.4;          ///< [%] mean slope north
  double hill_amplitude = 2.0;       ///< gentle undulation amplitude
  double hill_wavelength = 350.0;
  double fill_spacing = 32.0;  ///< corridor mode: candidate spacing of back-row buildings
  std::uint64_t seed = 1;

  /// Reads the keys above from a `scene:` map (plus `type`). Throws ConfigError naming the key.
  static UrbanSceneParams load(const ConfigNode& node);
};

/// A street grid of (blocks_x + 2) × (blocks_y + 2) blocks (the outer ring frames the drivable
/// part): facades with recesses and balconies, party walls, roofs, walls and trees in gaps,
/// parked cars, street lights, signs and trees along raised sidewalks with kerbs, on gently
/// sloping terrain. Blocks of the same type and buildings of the same template are identical.
/// The street intersections of the drivable part are at (i·block_length_x, j·block_length_y),
/// 0 ≤ i ≤ blocks_x, 0 ≤ j ≤ blocks_y.
GeneratedScene generateUrbanGrid(const UrbanSceneParams& params);

/// A city built around a given LiDAR trajectory (T_world_lidar): a road of street_half_width
/// each side of the path with kerbs and sidewalks, the ground following the path's height minus
/// `sensor_height`, buildings along the road and behind it, cars, lights and trees.
GeneratedScene generateUrbanAroundPath(const UrbanSceneParams& params, const Trajectory& path,
                                       double sensor_height);

/// A drive through the grid: the route visits grid intersections (i, j) in order, driving on the
/// right lane, with rounded corners and a speed profile. Poses are T_world_lidar.
struct DriveParams {
  /// Grid intersections to visit; empty = a default route of the outer loop and then a loop
  /// through the middle street, ending where it started (≈ 1.5 km with the default grid).
  std::vector<std::array<int, 2>> route;
  double speed = 10.0;          ///< [m/s] cruising speed
  double turn_speed = 4.5;      ///< [m/s] speed through corners
  double acceleration = 1.5;    ///< [m/s²] longitudinal limit
  double lane_offset = 2.0;     ///< [m] right of the centre line
  double turn_radius = 9.0;     ///< [m] corner radius
  double sensor_height = 1.73;  ///< [m] LiDAR above the road (KITTI: 1.73 m)
  double vibration_deg = 0.15;  ///< [deg] small body pitch/roll oscillation
  double rate_hz = 10.0;        ///< [Hz] pose rate (the LiDAR's)
  std::uint64_t seed = 1;

  /// Reads the keys above from a `trajectory:` map (plus `type`). Throws ConfigError.
  static DriveParams load(const ConfigNode& node);
};

/// The drive; throws ConfigError for a route that leaves the grid, jumps between
/// non-neighbouring intersections in a bent line, or turns back on itself.
Trajectory generateDrive(const UrbanSceneParams& scene, const GeneratedScene& generated,
                         const DriveParams& params);

// ---------------------------------------------------------------------------------------------
// Indoor

/// Parameters of the indoor generator. Lengths in metres.
struct IndoorSceneParams {
  int rooms_per_side = 3;       ///< rooms on each side of the corridor
  double room_width_min = 4.0;  ///< along the corridor
  double room_width_max = 6.0;
  double room_depth = 5.0;  ///< away from the corridor
  double corridor_width = 2.2;
  double wall_height = 2.7;
  double wall_thickness = 0.15;
  double door_width = 1.0;
  double door_height = 2.1;
  double clutter_per_room = 8.0;  ///< mean number of small objects per room
  /// Folder of OFF/PLY/OBJ meshes used as clutter ("" = procedural clutter only); the CGAL
  /// sample meshes (scripts/get_cgal_meshes.sh) are meant here.
  std::string mesh_dir;
  /// Mesh files (names in mesh_dir) to use; empty = every mesh of the folder up to max_meshes.
  std::vector<std::string> meshes;
  int max_meshes = 12;
  int max_mesh_faces = 20000;  ///< meshes are decimated by skipping when larger
  /// Room size for the TUM presets (a room built around the trajectory).
  double room_margin = 1.5;    ///< [m] free space around the trajectory's footprint
  double min_room_size = 5.0;  ///< [m]
  std::uint64_t seed = 1;

  /// Reads the keys above from a `scene:` map (plus `type`). Throws ConfigError naming the key.
  static IndoorSceneParams load(const ConfigNode& node);
};

/// An office floor: a corridor along x with rooms on both sides, doors (some open), tables,
/// chairs, shelves with books, cabinets, monitors and clutter (meshes from mesh_dir when given).
GeneratedScene generateIndoorFloor(const IndoorSceneParams& params);

/// A furnished room around a hand-held camera trajectory (T_world_camera, optical frame, z of
/// the world up): the room encloses the trajectory with `room_margin`, and a desk with clutter
/// stands where the camera mostly looks (the least-squares intersection of the optical axes).
GeneratedScene generateRoomAroundTrajectory(const IndoorSceneParams& params,
                                            const Trajectory& camera_path, double floor_z);

/// A hand-held walk through the indoor floor: from a room through its door, along the corridor,
/// into another room, around its table, and back to the start. Poses are T_world_camera
/// (optical frame).
struct WalkParams {
  double speed = 0.6;          ///< [m/s] walking speed
  double camera_height = 1.5;  ///< [m] above the floor
  double pitch_deg = -12.0;    ///< [deg] mean downward tilt
  double sway_deg = 12.0;      ///< [deg] slow left–right looking around
  double bob = 0.015;          ///< [m] step bobbing amplitude
  double rate_hz = 30.0;       ///< [Hz] pose rate (the camera's)
  std::uint64_t seed = 1;

  static WalkParams load(const ConfigNode& node);
};

Trajectory generateWalk(const IndoorSceneParams& scene, const GeneratedScene& generated,
                        const WalkParams& params);

// ---------------------------------------------------------------------------------------------
// Mesh files

/// Loads a scene from an OFF / PLY / OBJ file (all faces Material::Default), applying `scale`
/// and then T_world_mesh. Bounds: the mesh's box, 5 m higher. Throws IoError / FormatError naming
/// the file.
GeneratedScene loadMeshScene(const std::string& file, double scale = 1.0,
                             const Eigen::Isometry3d& T_world_mesh = Eigen::Isometry3d::Identity());

}  // namespace obm::sim
