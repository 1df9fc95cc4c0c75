#pragma once
// Private: the floor plan of the procedural indoor scene, computed from the parameters alone so
// that the scene generator and the walk generator agree on rooms and doors.
#include <Eigen/Core>
#include <vector>

#include "obm/sim/scenes.hpp"

namespace obm::sim::detail {

struct IndoorRoom {
  double x0, x1;   ///< extent along the corridor (wall centre lines)
  double y_wall;   ///< corridor wall centre line (y = ±corridor_width/2)
  double y_outer;  ///< outer wall centre line
  int side;        ///< −1 south, +1 north: the room's inward direction is +side·y
  double door_x;   ///< door centre along x
  /// Room-local point (u along x from x0, v from the corridor wall into the room) to world.
  Eigen::Vector2d toWorld(double u, double v) const {
    return Eigen::Vector2d(x0 + u, y_wall + side * v);
  }
  double width() const { return x1 - x0; }
  double depth() const { return side * (y_outer - y_wall); }
  /// Centre of the free area the walk circles in.
  Eigen::Vector2d freeCentre() const { return toWorld(0.5 * width(), 0.38 * depth()); }
};

struct IndoorLayout {
  double length = 0;                  ///< corridor length (x from 0)
  std::vector<IndoorRoom> rooms;      ///< south rooms first, then north rooms
  int start_room = 0, goal_room = 0;  ///< rooms the walk visits (their doors are open)
};

IndoorLayout indoorLayout(const IndoorSceneParams& p);

}  // namespace obm::sim::detail
