#include "obm/sim/preview.hpp"

#include <algorithm>
#include <cmath>

#include "obm/io/rgbd.hpp"
#include "obm/core/parallel.hpp"

namespace obm::sim {

void writePng(const std::string& path, const RgbImage& image) {
  io::ColorImage c;
  c.width = image.width;
  c.height = image.height;
  c.rgb = image.rgb;
  io::writeColorPng(path, c);
}

namespace {
// A perceptually ordered colour map (dark blue → cyan → green → yellow → red), t in [0, 1].
void colormap(double t, std::uint8_t& r, std::uint8_t& g, std::uint8_t& b) {
  static const double k[6][3] = {{0.19, 0.07, 0.23}, {0.16, 0.47, 0.93}, {0.10, 0.85, 0.75},
                                 {0.55, 0.98, 0.25}, {0.98, 0.73, 0.13}, {0.80, 0.10, 0.05}};
  t = std::clamp(t, 0.0, 1.0) * 5.0;
  const int i = std::min(4, static_cast<int>(t));
  const double a = t - i;
  r = static_cast<std::uint8_t>(255 * ((1 - a) * k[i][0] + a * k[i + 1][0]));
  g = static_cast<std::uint8_t>(255 * ((1 - a) * k[i][1] + a * k[i + 1][1]));
  b = static_cast<std::uint8_t>(255 * ((1 - a) * k[i][2] + a * k[i + 1][2]));
}

void disc(RgbImage& im, int cx, int cy, int rad, std::uint8_t r, std::uint8_t g, std::uint8_t b) {
  for (int y = -rad; y <= rad; ++y)
    for (int x = -rad; x <= rad; ++x)
      if (x * x + y * y <= rad * rad) im.set(cx + x, cy + y, r, g, b);
}

void line(RgbImage& im, double x0, double y0, double x1, double y1, int rad, std::uint8_t r,
          std::uint8_t g, std::uint8_t b) {
  const int n =
      std::max(1, static_cast<int>(std::ceil(std::max(std::fabs(x1 - x0), std::fabs(y1 - y0)))));
  for (int k = 0; k <= n; ++k) {
    const double a = static_cast<double>(k) / n;
    disc(im, static_cast<int>(std::lround(x0 + a * (x1 - x0))),
         static_cast<int>(std::lround(y0 + a * (y1 - y0))), rad, r, g, b);
  }
}
}  // namespace

RgbImage renderTopView(const RaycastScene& scene, const Eigen::AlignedBox3d& region, double z_top,
                       const Trajectory& traj, int max_pixels, int threads) {
  const double wx = region.sizes().x(), wy = region.sizes().y();
  const double res = std::max(wx, wy) / std::max(16, max_pixels);
  const int W = std::max(1, static_cast<int>(std::ceil(wx / res)));
  const int H = std::max(1, static_cast<int>(std::ceil(wy / res)));
  RgbImage im(W, H, 255);
  const Eigen::Vector3f light = Eigen::Vector3f(-0.4f, 0.5f, 0.77f).normalized();
  const double zlo = region.min().z(), zhi = std::max(region.max().z(), zlo + 1.0);
  parallelFor(static_cast<std::size_t>(H), threads, [&](std::size_t row) {
    std::vector<Eigen::Vector3f> o(static_cast<std::size_t>(W)),
        d(static_cast<std::size_t>(W), Eigen::Vector3f(0, 0, -1));
    const double y = region.max().y() - (static_cast<double>(row) + 0.5) * res;
    for (int c = 0; c < W; ++c)
      o[static_cast<std::size_t>(c)] =
          Eigen::Vector3f(static_cast<float>(region.min().x() + (c + 0.5) * res),
                          static_cast<float>(y), static_cast<float>(z_top));
    std::vector<RayHit> hits;
    const float tmax = static_cast<float>(z_top - zlo + 50.0);
    scene.intersect(o, d, 0.f, tmax, hits);
    for (int c = 0; c < W; ++c) {
      RayHit h = hits[static_cast<std::size_t>(c)];
      // Look past ceilings into the rooms.
      for (int k = 0; k < 4 && h.hit() && h.material == Material::Ceiling; ++k)
        h = scene.intersect(o[static_cast<std::size_t>(c)], d[static_cast<std::size_t>(c)],
                            h.range + 1e-4f, tmax);
      if (!h.hit()) continue;
      const auto& mp = materialProperties(h.material);
      // Lambert shading plus a little height tint so tall things stand out.
      const double z = z_top - h.range;
      const float shade = 0.45f + 0.55f * std::max(0.f, h.normal.dot(light)) *
                                      static_cast<float>(0.8 + 0.4 * (z - zlo) / (zhi - zlo));
      im.set(c, static_cast<int>(row),
             static_cast<std::uint8_t>(std::min(255.f, mp.rgb[0] * shade)),
             static_cast<std::uint8_t>(std::min(255.f, mp.rgb[1] * shade)),
             static_cast<std::uint8_t>(std::min(255.f, mp.rgb[2] * shade)));
    }
  });
  auto px = [&](const Eigen::Vector3d& p, double& x, double& y) {
    x = (p.x() - region.min().x()) / res;
    y = (region.max().y() - p.y()) / res;
  };
  const int rad = std::max(1, W / 600);
  for (std::size_t k = 1; k < traj.size(); ++k) {
    double xa, ya, xb, yb;
    px(traj.poses[k - 1].translation(), xa, ya);
    px(traj.poses[k].translation(), xb, yb);
    line(im, xa, ya, xb, yb, rad, 220, 20, 20);
  }
  if (!traj.empty()) {
    double x, y;
    px(traj.poses.back().translation(), x, y);
    disc(im, static_cast<int>(x), static_cast<int>(y), 4 * rad + 2, 20, 20, 220);
    px(traj.poses.front().translation(), x, y);
    disc(im, static_cast<int>(x), static_cast<int>(y), 3 * rad + 2, 20, 200, 20);
  }
  return im;
}

RgbImage renderSweep(const LidarSweep& s, std::size_t rings, std::size_t columns, double range,
                     int size) {
  const int strip_h = static_cast<int>(std::max<std::size_t>(1, rings)) * (rings <= 32 ? 4 : 2);
  RgbImage im(size, size + strip_h, 15);
  const double scale = size / (2.0 * range);
  // Bird's-eye view, x forward = up in the picture, y left = left.
  std::vector<std::size_t> order(s.cloud.size());
  for (std::size_t i = 0; i < order.size(); ++i) order[i] = i;
  std::sort(order.begin(), order.end(), [&](std::size_t a, std::size_t b) {
    return s.cloud.points[a].z() < s.cloud.points[b].z();
  });
  for (std::size_t i : order) {
    const auto& p = s.cloud.points[i];
    const int u = static_cast<int>(size / 2 - p.y() * scale),
              v = static_cast<int>(size / 2 - p.x() * scale);
    std::uint8_t r, g, b;
    colormap((p.z() + 2.5) / 8.0, r, g, b);
    im.set(u, v, r, g, b);
  }
  disc(im, size / 2, size / 2, 3, 255, 255, 255);
  // Range image: columns resampled to the picture width.
  const int rh = strip_h / static_cast<int>(std::max<std::size_t>(1, rings));
  for (std::size_t i = 0; i < s.cloud.size() && i < s.ring.size() && i < s.column.size(); ++i) {
    const int u = static_cast<int>(static_cast<double>(s.column[i]) * size /
                                   std::max<std::size_t>(1, columns));
    std::uint8_t r, g, b;
    colormap(std::sqrt(s.cloud.points[i].norm() / (2.0 * range)), r, g, b);
    for (int k = 0; k < rh; ++k) im.set(u, size + static_cast<int>(s.ring[i]) * rh + k, r, g, b);
  }
  return im;
}

RgbImage renderDepthFrame(const DepthFrame& f, double max_depth) {
  RgbImage im(2 * f.width, f.height, 0);
  for (int v = 0; v < f.height; ++v)
    for (int u = 0; u < f.width; ++u) {
      const float z = f.at(u, v);
      if (z > 0.f) {
        std::uint8_t r, g, b;
        colormap(z / max_depth, r, g, b);
        im.set(u, v, r, g, b);
      }
      if (!f.rgb.empty()) {
        const std::size_t k = 3 * (static_cast<std::size_t>(v) * f.width + u);
        im.set(f.width + u, v, f.rgb[k], f.rgb[k + 1], f.rgb[k + 2]);
      }
    }
  return im;
}

}  // namespace obm::sim
