#pragma once
/// \file preview.hpp
/// Pictures of what was simulated, for a person to look at: a top view of the scene with the
/// trajectory, a bird's-eye view + range image of one LiDAR sweep, and a depth + colour view of
/// one RGB-D frame.
#include <cstdint>
#include <string>
#include <vector>

#include "obm/sim/lidar.hpp"
#include "obm/sim/rgbd_camera.hpp"
#include "obm/sim/scene.hpp"
#include "obm/sim/trajectory.hpp"

namespace obm::sim {

/// 8-bit RGB image, row-major.
struct RgbImage {
  int width = 0, height = 0;
  std::vector<std::uint8_t> rgb;
  RgbImage() = default;
  RgbImage(int w, int h, std::uint8_t grey = 0)
      : width(w), height(h), rgb(static_cast<std::size_t>(w) * h * 3, grey) {}
  void set(int x, int y, std::uint8_t r, std::uint8_t g, std::uint8_t b) {
    if (x < 0 || y < 0 || x >= width || y >= height) return;
    const std::size_t k = 3 * (static_cast<std::size_t>(y) * width + x);
    rgb[k] = r;
    rgb[k + 1] = g;
    rgb[k + 2] = b;
  }
};

/// Writes a PNG atomically (IoError naming the file on failure).
void writePng(const std::string& path, const RgbImage& image);

/// Orthographic view from above of `region` (x right = east, up = north), shaded by the surface
/// normal and coloured by material, rays starting at `z_top` downwards (set it below a ceiling
/// to see into rooms). The trajectory is drawn in red, its start in green. The longer side has
/// `max_pixels` pixels.
RgbImage renderTopView(const RaycastScene& scene, const Eigen::AlignedBox3d& region, double z_top,
                       const Trajectory& trajectory, int max_pixels = 1200, int threads = 0);

/// A LiDAR sweep: bird's-eye view (±`range` m, points coloured by height) above its range image
/// (one row per ring, coloured by range).
RgbImage renderSweep(const LidarSweep& sweep, std::size_t rings, std::size_t columns,
                     double range = 50.0, int size = 800);

/// An RGB-D frame: depth (colour-mapped, black = no measurement) beside the shaded colour image.
RgbImage renderDepthFrame(const DepthFrame& frame, double max_depth);

}  // namespace obm::sim
