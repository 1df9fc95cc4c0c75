// Top-view picture of a trajectory against its reference (obm::slam::writeTrajectoryPng).
#include <algorithm>
#include <cmath>

#include "obm/core/errors.hpp"
#include "obm/io/rgbd.hpp"
#include "obm/slam/mapping_app.hpp"

namespace obm::slam {

namespace {

struct Canvas {
  io::ColorImage img;
  double x_min = 0, y_max = 0, scale = 1;  // pixel = (x − x_min)·scale, (y_max − y)·scale

  void dot(double px, double py, int radius, const Color3u8& c) {
    const int cx = static_cast<int>(std::lround(px)), cy = static_cast<int>(std::lround(py));
    for (int dy = -radius; dy <= radius; ++dy)
      for (int dx = -radius; dx <= radius; ++dx) {
        if (dx * dx + dy * dy > radius * radius) continue;
        const int u = cx + dx, v = cy + dy;
        if (u < 0 || v < 0 || u >= img.width || v >= img.height) continue;
        const std::size_t k = 3 * (static_cast<std::size_t>(v) * img.width + u);
        img.rgb[k] = c(0);
        img.rgb[k + 1] = c(1);
        img.rgb[k + 2] = c(2);
      }
  }
  Eigen::Vector2d toPixel(const Eigen::Vector2d& p) const {
    return {(p.x() - x_min) * scale, (y_max - p.y()) * scale};
  }
  /// A line of dots half a pixel apart (simple and thick enough for a plot).
  void line(const Eigen::Vector2d& a, const Eigen::Vector2d& b, int radius, const Color3u8& c) {
    const Eigen::Vector2d pa = toPixel(a), pb = toPixel(b);
    const double len = (pb - pa).norm();
    const int steps = std::max(1, static_cast<int>(std::ceil(2.0 * len)));
    for (int s = 0; s <= steps; ++s) {
      const Eigen::Vector2d p = pa + (pb - pa) * (static_cast<double>(s) / steps);
      dot(p.x(), p.y(), radius, c);
    }
  }
};

}  // namespace

double writeTrajectoryPng(const std::string& path, const std::vector<Isometry3d>& estimate,
                          const std::vector<Isometry3d>& reference,
                          const std::vector<std::pair<std::size_t, std::size_t>>& loops,
                          const Isometry3d& T_view_world, int max_pixels) {
  OBM_ASSERT(!estimate.empty(), "writeTrajectoryPng: empty estimate");
  OBM_ASSERT(max_pixels >= 64, "writeTrajectoryPng: max_pixels must be >= 64");
  auto xy = [&](const Isometry3d& T) {
    const Eigen::Vector3d p = T_view_world * T.translation();
    return Eigen::Vector2d(p.x(), p.y());
  };
  std::vector<Eigen::Vector2d> est, ref;
  for (const auto& T : estimate) est.push_back(xy(T));
  for (const auto& T : reference) ref.push_back(xy(T));
  Eigen::Vector2d lo = est.front(), hi = est.front();
  for (const auto* v : {&est, &ref})
    for (const auto& p : *v) {
      lo = lo.cwiseMin(p);
      hi = hi.cwiseMax(p);
    }
  // A margin of 5 % (at least 2 m) around the paths.
  const double margin = std::max(2.0, 0.05 * (hi - lo).maxCoeff());
  lo.array() -= margin;
  hi.array() += margin;
  const double extent = (hi - lo).maxCoeff();
  Canvas cv;
  cv.scale = static_cast<double>(max_pixels) / extent;
  cv.x_min = lo.x();
  cv.y_max = hi.y();
  cv.img.width = std::max(16, static_cast<int>(std::ceil((hi.x() - lo.x()) * cv.scale)));
  cv.img.height = std::max(16, static_cast<int>(std::ceil((hi.y() - lo.y()) * cv.scale)));
  cv.img.rgb.assign(static_cast<std::size_t>(cv.img.width) * cv.img.height * 3, 255);

  // Grid: a light line every 10^k, 2·10^k or 5·10^k metres (about 10 lines across).
  double step = std::pow(10.0, std::floor(std::log10(extent / 10.0)));
  if (extent / step > 25)
    step *= 5;
  else if (extent / step > 12)
    step *= 2;
  const Color3u8 grid(225, 225, 225);
  for (double x = std::ceil(lo.x() / step) * step; x <= hi.x(); x += step)
    cv.line({x, lo.y()}, {x, hi.y()}, 0, grid);
  for (double y = std::ceil(lo.y() / step) * step; y <= hi.y(); y += step)
    cv.line({lo.x(), y}, {hi.x(), y}, 0, grid);

  const int r = std::max(1, max_pixels / 800);
  for (std::size_t i = 1; i < ref.size(); ++i)
    cv.line(ref[i - 1], ref[i], r + 1, Color3u8(0, 0, 0));
  for (const auto& [a, b] : loops)
    if (a < est.size() && b < est.size()) cv.line(est[a], est[b], r, Color3u8(40, 90, 255));
  for (std::size_t i = 1; i < est.size(); ++i)
    cv.line(est[i - 1], est[i], r, Color3u8(220, 30, 30));
  const Eigen::Vector2d s = cv.toPixel(est.front());
  cv.dot(s.x(), s.y(), 4 * r + 2, Color3u8(0, 170, 0));
  io::writeColorPng(path, cv.img);
  return 1.0 / cv.scale;
}

}  // namespace obm::slam
