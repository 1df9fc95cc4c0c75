#pragma once
// Private: the objects procedural scenes are assembled from. Every function appends closed
// solids (or one-sided facades backed by solids) to a MeshBuilder. Frames: T is T_world_object;
// object frames have z up and sit on the ground at z = 0 unless stated.
#include <Eigen/Geometry>
#include <cstdint>

#include "obm/sim/geometry.hpp"
#include "obm/sim/random.hpp"

namespace obm::sim::detail {

/// The look of a building; one style is shared by every building made from the same template,
/// which is what makes streets repeat.
struct BuildingStyle {
  int floors = 4;
  double floor_height = 3.0;   ///< [m]
  double ground_height = 3.6;  ///< [m] ground floor
  double bay_width = 3.2;      ///< [m] window spacing
  double window_width = 1.4;   ///< [m]
  double window_height = 1.5;  ///< [m]
  double sill = 0.9;           ///< [m] window bottom above the floor
  double recess = 0.25;        ///< [m] depth of the window recesses
  int balcony_pattern = 0;     ///< 0 none, 1 every bay, 2 alternate bays, 3 central bays
  double balcony_depth = 1.2;  ///< [m]
  bool shop_front = false;     ///< large recessed glass on the ground floor
  bool gable_roof = false;     ///< pitched roof (else flat with a parapet)
  double roof_height = 3.5;    ///< [m] gable height
  double parapet = 0.8;        ///< [m] flat-roof parapet height
  double height() const { return ground_height + (floors - 1) * floor_height; }
};

/// Draws a style from `rng` with `min_floors`..`max_floors` storeys.
BuildingStyle randomBuildingStyle(Rng& rng, int min_floors, int max_floors);

/// A building with footprint [0, W]×[0, D] in the frame T: the street facade is the plane y = 0
/// facing −y, with window recesses, balconies and an entrance; the back (y = D) has plain window
/// recesses; the sides are plain when `party_walls` (terraced houses) or windowed otherwise.
/// Walls run from z = z_base (below ground, to absorb the slope) to the roof.
void addBuilding(MeshBuilder& b, const Eigen::Isometry3d& T, double W, double D, double z_base,
                 const BuildingStyle& s, bool party_walls, std::uint64_t seed);

/// A parked car centred at the origin of T (x forward, on the ground). Its size and type come
/// from `rng`.
void addCar(MeshBuilder& b, const Eigen::Isometry3d& T, Rng& rng);

/// A deciduous tree standing at `base`.
void addTree(MeshBuilder& b, const Eigen::Vector3d& base, Rng& rng);

/// A street light at `base` whose arm points along `yaw` [rad].
void addStreetLight(MeshBuilder& b, const Eigen::Vector3d& base, double yaw);

/// A traffic sign (pole + plate) at `base` facing `yaw`.
void addSign(MeshBuilder& b, const Eigen::Vector3d& base, double yaw, Rng& rng);

/// A straight wall from a to b (ground points), `height` tall and `thickness` thick, reaching
/// down to `z_below` under the lower end.
void addWall(MeshBuilder& b, const Eigen::Vector3d& a, const Eigen::Vector3d& c, double height,
             double thickness, Material m);

/// A box oriented along the segment a→c on the ground (hedges, kerb stones, benches).
void addOrientedBox(MeshBuilder& b, const Eigen::Vector3d& a, const Eigen::Vector3d& c,
                    double width, double z0, double z1, Material m);

// --- indoor furniture (origin on the floor, x along the long side) ----------------------------

/// A table with four legs; top at `height`. Returns the top's height.
double addTable(MeshBuilder& b, const Eigen::Isometry3d& T, double length, double width,
                double height);
/// A chair (seat 0.45 m, backrest towards −x).
void addChair(MeshBuilder& b, const Eigen::Isometry3d& T);
/// A shelf unit, back against y = depth, with `levels` boards and books on them.
void addShelf(MeshBuilder& b, const Eigen::Isometry3d& T, double length, double depth,
              double height, int levels, Rng& rng);
/// A cabinet / sideboard block.
void addCabinet(MeshBuilder& b, const Eigen::Isometry3d& T, double length, double depth,
                double height);
/// A monitor on a foot, facing −x... placed on a table top at the origin of T.
void addMonitor(MeshBuilder& b, const Eigen::Isometry3d& T);
/// Small procedural clutter (box, cylinder, blob) standing at the origin of T.
void addSmallObject(MeshBuilder& b, const Eigen::Isometry3d& T, Rng& rng);

}  // namespace obm::sim::detail
