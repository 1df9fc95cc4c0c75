// Top view of an occupancy map: one pixel per (x, y) column, coloured by the height of the
// highest occupied voxel in it.
#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <vector>

#include "obm/core/errors.hpp"
#include "obm/mapping/occupancy_map.hpp"
#include "tree_access.hpp"

namespace obm::mapping {

namespace {

// Height colour map: piecewise linear through blue, cyan, green, yellow and red, so low and high
// are told apart without a legend and no colour is close to the free (grey) or unknown (white).
Color3u8 heightColor(double t) {
  static const std::array<std::array<double, 3>, 5> stops{{{{0.15, 0.25, 0.85}},
                                                           {{0.0, 0.75, 0.9}},
                                                           {{0.1, 0.75, 0.2}},
                                                           {{0.95, 0.85, 0.1}},
                                                           {{0.85, 0.1, 0.1}}}};
  t = std::clamp(t, 0.0, 1.0) * (stops.size() - 1);
  const std::size_t i = std::min<std::size_t>(static_cast<std::size_t>(t), stops.size() - 2);
  const double f = t - static_cast<double>(i);
  Color3u8 c;
  for (int k = 0; k < 3; ++k)
    c[k] = static_cast<std::uint8_t>(
        std::lround(255.0 * ((1.0 - f) * stops[i][k] + f * stops[i + 1][k])));
  return c;
}

constexpr std::uint8_t kFreeGrey = 205;
constexpr std::uint8_t kUnknownWhite = 255;

}  // namespace

TopView OccupancyMap::renderTopView(const TopViewOptions& options) const {
  const MapStats s = stats();
  if (s.empty()) throw ContractError("renderTopView: the map is empty");
  if (options.max_pixels < 1) throw ContractError("renderTopView: max_pixels must be >= 1");
  const double res = impl_->params.resolution;
  TopViewInfo info;
  info.pixel_size = options.pixel_size > 0.0 ? options.pixel_size : res;
  const double ex = s.bbox_max.x() - s.bbox_min.x(), ey = s.bbox_max.y() - s.bbox_min.y();
  // Leaf bounds lie on the grid, so the extent is a whole number of voxels up to round-off.
  constexpr double kEps = 1e-6;
  const auto pixelsFor = [&](double extent, double px) {
    return std::max(1, static_cast<int>(std::ceil(extent / px - kEps)));
  };
  const double longest = std::max(ex, ey);
  if (pixelsFor(longest, info.pixel_size) > options.max_pixels)
    info.pixel_size = longest / options.max_pixels;
  info.width = pixelsFor(ex, info.pixel_size);
  info.height = pixelsFor(ey, info.pixel_size);
  info.x_min = s.bbox_min.x();
  info.y_max = s.bbox_max.y();

  const std::size_t n = static_cast<std::size_t>(info.width) * info.height;
  std::vector<double> top(n, -std::numeric_limits<double>::infinity());
  std::vector<Color3u8> top_rgb(n, Color3u8::Zero());
  std::vector<bool> known(n, false);
  const double px = info.pixel_size;
  const bool use_rgb = options.use_voxel_color && impl_->kind == MapKind::Color;

  impl_->visit([&](auto& tree) {
    using Tree = std::decay_t<decltype(tree)>;
    for (auto it = tree.begin_leafs(), end = tree.end_leafs(); it != end; ++it) {
      const double size = it.getSize();
      // Centres of the finest voxels inside this (possibly pruned) leaf span
      // [z − size/2 + res/2, z + size/2 − res/2]; keep the part within [z_min, z_max].
      const double zc_lo = it.getZ() - 0.5 * size + 0.5 * res;
      const double zc_hi = it.getZ() + 0.5 * size - 0.5 * res;
      if (zc_hi < options.z_min || zc_lo > options.z_max) continue;
      const double z_top = std::min(zc_hi, options.z_max);
      const int c0 = std::max(
          0, static_cast<int>(std::floor((it.getX() - 0.5 * size - info.x_min) / px + kEps)));
      const int c1 =
          std::min(info.width,
                   static_cast<int>(std::ceil((it.getX() + 0.5 * size - info.x_min) / px - kEps)));
      const int r0 = std::max(
          0, static_cast<int>(std::floor((info.y_max - (it.getY() + 0.5 * size)) / px + kEps)));
      const int r1 = std::min(
          info.height,
          static_cast<int>(std::ceil((info.y_max - (it.getY() - 0.5 * size)) / px - kEps)));
      const bool occupied = tree.isNodeOccupied(*it);
      Color3u8 rgb = Color3u8::Zero();
      if constexpr (std::is_same_v<Tree, octomap::ColorOcTree>) {
        if (occupied && use_rgb) {
          const auto c = it->getColor();
          rgb = Color3u8(c.r, c.g, c.b);
        }
      }
      for (int r = r0; r < r1; ++r)
        for (int c = c0; c < c1; ++c) {
          const std::size_t k = static_cast<std::size_t>(r) * info.width + c;
          known[k] = true;
          if (occupied && z_top > top[k]) {
            top[k] = z_top;
            top_rgb[k] = rgb;
          }
        }
    }
  });

  // The colour range spans the 1st to 99th percentile of the column heights, so that a few stray
  // returns far below the ground or above the roofs do not squeeze everything else into one colour.
  std::vector<double> heights;
  for (double z : top)
    if (std::isfinite(z)) heights.push_back(z);
  if (heights.empty()) {
    info.z_low = info.z_high = 0.0;
  } else {
    const auto at = [&](double q) {
      const std::size_t k = static_cast<std::size_t>(q * static_cast<double>(heights.size() - 1));
      std::nth_element(heights.begin(), heights.begin() + k, heights.end());
      return heights[k];
    };
    info.z_low = at(0.01);
    info.z_high = at(0.99);
  }
  const double span = std::max(info.z_high - info.z_low, 1e-9);

  TopView img;
  img.rgb.assign(3 * n, kUnknownWhite);
  for (std::size_t k = 0; k < n; ++k) {
    Color3u8 c = Color3u8::Constant(kUnknownWhite);
    if (std::isfinite(top[k])) {
      c = use_rgb ? top_rgb[k] : heightColor((top[k] - info.z_low) / span);
      ++info.occupied_pixels;
    } else if (known[k]) {
      c = Color3u8::Constant(kFreeGrey);
      ++info.free_pixels;
    }
    for (int ch = 0; ch < 3; ++ch) img.rgb[3 * k + ch] = c[ch];
  }
  img.info = info;
  return img;
}

}  // namespace obm::mapping
