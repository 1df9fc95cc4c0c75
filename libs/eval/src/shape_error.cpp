#include "obm/eval/shape_error.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numeric>

#include <Eigen/Eigenvalues>

#include "obm/core/errors.hpp"

namespace obm::eval {

namespace {

std::int64_t cellKey(std::int64_t x, std::int64_t y, std::int64_t z) {
  return (x & 0x1FFFFF) | ((y & 0x1FFFFF) << 21) | ((z & 0x1FFFFF) << 42);
}

}  // namespace

std::int64_t SurfaceErrorScorer::keyOf(const Vector3f& p) const {
  const Vector3f q = p / cell_;
  return cellKey(static_cast<std::int64_t>(std::floor(q.x())),
                 static_cast<std::int64_t>(std::floor(q.y())),
                 static_cast<std::int64_t>(std::floor(q.z())));
}

void SurfaceErrorScorer::neighbours(const Vector3f& p, std::vector<std::size_t>& out) const {
  out.clear();
  const Vector3f q = p / cell_;
  const auto cx = static_cast<std::int64_t>(std::floor(q.x()));
  const auto cy = static_cast<std::int64_t>(std::floor(q.y()));
  const auto cz = static_cast<std::int64_t>(std::floor(q.z()));
  for (std::int64_t dx = -1; dx <= 1; ++dx)
    for (std::int64_t dy = -1; dy <= 1; ++dy)
      for (std::int64_t dz = -1; dz <= 1; ++dz) {
        const auto it = grid_.find(cellKey(cx + dx, cy + dy, cz + dz));
        if (it != grid_.end()) out.insert(out.end(), it->second.begin(), it->second.end());
      }
}

SurfaceErrorScorer::SurfaceErrorScorer(const PointCloud& object, int normal_neighbours)
    : points_(object.points) {
  const std::size_t n = points_.size();
  if (n < 16)
    throw ContractError("SurfaceErrorScorer: '" + object.frame_id + "' has " +
                        std::to_string(n) + " samples, needs at least 16");
  // The grid's cell from the samples' density: the mean spacing of n samples spread over the
  // bounding box's surface, times 4, so that a cell's 27 neighbours hold every sample within
  // 2 spacings and enough for a normal. (The median spacing is measured below, on the grid.)
  Vector3f lo = points_[0], hi = points_[0];
  for (const auto& p : points_) {
    lo = lo.cwiseMin(p);
    hi = hi.cwiseMax(p);
  }
  const Vector3f e = (hi - lo).cwiseMax(1e-6f);
  const double area = 2.0 * (e.x() * e.y() + e.y() * e.z() + e.x() * e.z());
  cell_ = static_cast<float>(4.0 * std::sqrt(area / static_cast<double>(n)));
  for (std::size_t i = 0; i < n; ++i) grid_[keyOf(points_[i])].push_back(i);

  const auto k = static_cast<std::size_t>(std::max(3, normal_neighbours));
  normals_.resize(n);
  std::vector<float> nn(n);
  std::vector<std::size_t> cand;
  std::vector<float> d2;
  for (std::size_t i = 0; i < n; ++i) {
    neighbours(points_[i], cand);
    d2.resize(cand.size());
    for (std::size_t j = 0; j < cand.size(); ++j)
      d2[j] = (points_[cand[j]] - points_[i]).squaredNorm();
    std::vector<std::size_t> order(cand.size());
    std::iota(order.begin(), order.end(), std::size_t{0});
    const std::size_t kk = std::min(k, order.size());
    std::partial_sort(order.begin(), order.begin() + static_cast<std::ptrdiff_t>(kk), order.end(),
                      [&](std::size_t a, std::size_t b) { return d2[a] < d2[b]; });
    // order[0] is the point itself; a lone point gets the cell size as its spacing.
    nn[i] = kk > 1 ? std::sqrt(d2[order[1]]) : cell_;
    if (kk < 3) {
      normals_[i] = Vector3f::UnitZ();
      continue;
    }
    Eigen::Vector3d mean = Eigen::Vector3d::Zero();
    for (std::size_t a = 0; a < kk; ++a) mean += points_[cand[order[a]]].cast<double>();
    mean /= static_cast<double>(kk);
    Eigen::Matrix3d C = Eigen::Matrix3d::Zero();
    for (std::size_t a = 0; a < kk; ++a) {
      const Eigen::Vector3d d = points_[cand[order[a]]].cast<double>() - mean;
      C += d * d.transpose();
    }
    // The eigenvector of the smallest eigenvalue (sorted ascending) is the plane's normal.
    Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> es(C);
    normals_[i] = es.eigenvectors().col(0).cast<float>();
  }
  std::nth_element(nn.begin(), nn.begin() + static_cast<std::ptrdiff_t>(n / 2), nn.end());
  spacing_ = nn[n / 2];
}

double SurfaceErrorScorer::error(const Isometry3d& T_pred, const Isometry3d& T_gt) const {
  const Eigen::Isometry3f dT = (T_gt.inverse() * T_pred).cast<float>();
  const float off = static_cast<float>(3.0 * spacing_);
  std::vector<std::size_t> cand;
  double sum = 0.0;
  for (const auto& x : points_) {
    const Vector3f p = dT * x;
    neighbours(p, cand);
    float best = std::numeric_limits<float>::max();
    std::size_t j = 0;
    for (const std::size_t c : cand) {
      const float e = (points_[c] - p).squaredNorm();
      if (e < best) {
        best = e;
        j = c;
      }
    }
    // Farther than one cell from every sample: counted as one cell (the distance is capped).
    const float d = cand.empty() ? cell_ : std::min(std::sqrt(best), cell_);
    sum += d > off ? d : std::abs(normals_[j].dot(p - points_[j]));
  }
  return sum / static_cast<double>(points_.size());
}

}  // namespace obm::eval
