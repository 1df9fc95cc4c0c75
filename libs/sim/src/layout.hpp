#pragma once
// Private 2D layout helpers of the procedural scenes: distance to a network of polylines (roads,
// walking paths) through a bucket grid, and an occupancy raster that keeps objects apart.
#include <Eigen/Core>
#include <algorithm>
#include <cmath>
#include <limits>
#include <unordered_map>
#include <vector>

namespace obm::sim::detail {

using V2 = Eigen::Vector2d;

/// Segments with a bucket grid for "distance to the nearest segment" queries.
class SegmentIndex {
 public:
  explicit SegmentIndex(double cell = 16.0) : cell_(cell) {}

  /// Adds a polyline; returns nothing. `value` per vertex (e.g. ground height) is interpolated.
  void addPolyline(const std::vector<V2>& pts, const std::vector<double>& values = {}) {
    for (std::size_t i = 0; i + 1 < pts.size(); ++i) {
      const double va = values.empty() ? 0.0 : values[i], vb = values.empty() ? 0.0 : values[i + 1];
      addSegment(pts[i], pts[i + 1], va, vb);
    }
  }

  void addSegment(const V2& a, const V2& b, double va = 0.0, double vb = 0.0) {
    const int id = static_cast<int>(seg_.size());
    seg_.push_back({a, b, va, vb});
    const int i0 = key(std::min(a.x(), b.x())), i1 = key(std::max(a.x(), b.x()));
    const int j0 = key(std::min(a.y(), b.y())), j1 = key(std::max(a.y(), b.y()));
    for (int i = i0; i <= i1; ++i)
      for (int j = j0; j <= j1; ++j) grid_[pack(i, j)].push_back(id);
  }

  /// Distance to the nearest segment within `max_r` (max_r when none); optionally the value
  /// interpolated at the nearest point and the segment's unit direction.
  double distance(const V2& p, double max_r, double* value = nullptr, V2* dir = nullptr) const {
    double best = max_r;
    const int r = static_cast<int>(std::ceil(max_r / cell_));
    const int ci = key(p.x()), cj = key(p.y());
    for (int i = ci - r; i <= ci + r; ++i)
      for (int j = cj - r; j <= cj + r; ++j) {
        const auto it = grid_.find(pack(i, j));
        if (it == grid_.end()) continue;
        for (int id : it->second) {
          const Seg& s = seg_[static_cast<std::size_t>(id)];
          const V2 ab = s.b - s.a;
          const double L2 = ab.squaredNorm();
          const double t = L2 > 0 ? std::clamp((p - s.a).dot(ab) / L2, 0.0, 1.0) : 0.0;
          const double d = (s.a + t * ab - p).norm();
          if (d < best) {
            best = d;
            if (value) *value = (1 - t) * s.va + t * s.vb;
            if (dir && L2 > 0) *dir = ab / std::sqrt(L2);
          }
        }
      }
    return best;
  }

  /// Distance to the nearest segment at any distance (expanding search); ∞ when empty.
  double nearest(const V2& p, double* value = nullptr, V2* dir = nullptr) const {
    if (seg_.empty()) return std::numeric_limits<double>::infinity();
    for (double R = 2.0 * cell_;; R *= 2.0) {
      const double d = distance(p, R, value, dir);
      if (d < R - cell_) return d;
      if (R > 1e7) return d;
    }
  }

  bool empty() const { return seg_.empty(); }

 private:
  struct Seg {
    V2 a, b;
    double va, vb;
  };
  int key(double v) const { return static_cast<int>(std::floor(v / cell_)); }
  static unsigned long long pack(int i, int j) {
    return (static_cast<unsigned long long>(static_cast<unsigned>(i)) << 32) |
           static_cast<unsigned long long>(static_cast<unsigned>(j));
  }
  double cell_;
  std::vector<Seg> seg_;
  std::unordered_map<unsigned long long, std::vector<int>> grid_;
};

/// A boolean raster over a rectangle; oriented rectangles are tested and marked by their cells.
class Occupancy {
 public:
  Occupancy() = default;
  Occupancy(double x0, double y0, double x1, double y1, double res)
      : x0_(x0),
        y0_(y0),
        res_(res),
        nx_(std::max(1, static_cast<int>(std::ceil((x1 - x0) / res)))),
        ny_(std::max(1, static_cast<int>(std::ceil((y1 - y0) / res)))),
        cells_(static_cast<std::size_t>(nx_) * ny_, 0) {}

  /// Oriented rectangle: centre c, half sizes h (along its x / y), heading yaw; `margin` grows it.
  bool isFree(const V2& c, const V2& h, double yaw, double margin = 0.0) const {
    bool free = true;
    visit(c, h + V2(margin, margin), yaw, [&](std::size_t k) {
      if (cells_[k]) free = false;
    });
    return free;
  }
  void mark(const V2& c, const V2& h, double yaw) {
    visit(c, h, yaw, [&](std::size_t k) { cells_[k] = 1; });
  }

 private:
  template <typename F>
  void visit(const V2& c, const V2& h, double yaw, F&& f) const {
    const double cs = std::cos(yaw), sn = std::sin(yaw);
    const double ex = std::abs(cs) * h.x() + std::abs(sn) * h.y();
    const double ey = std::abs(sn) * h.x() + std::abs(cs) * h.y();
    const int i0 = std::max(0, static_cast<int>(std::floor((c.x() - ex - x0_) / res_)));
    const int i1 = std::min(nx_ - 1, static_cast<int>(std::floor((c.x() + ex - x0_) / res_)));
    const int j0 = std::max(0, static_cast<int>(std::floor((c.y() - ey - y0_) / res_)));
    const int j1 = std::min(ny_ - 1, static_cast<int>(std::floor((c.y() + ey - y0_) / res_)));
    for (int j = j0; j <= j1; ++j)
      for (int i = i0; i <= i1; ++i) {
        const V2 q(x0_ + (i + 0.5) * res_ - c.x(), y0_ + (j + 0.5) * res_ - c.y());
        const double lx = cs * q.x() + sn * q.y(), ly = -sn * q.x() + cs * q.y();
        if (std::abs(lx) <= h.x() + 0.5 * res_ && std::abs(ly) <= h.y() + 0.5 * res_)
          f(static_cast<std::size_t>(j) * nx_ + i);
      }
  }
  double x0_ = 0, y0_ = 0, res_ = 1;
  int nx_ = 0, ny_ = 0;
  std::vector<unsigned char> cells_;
};

}  // namespace obm::sim::detail
