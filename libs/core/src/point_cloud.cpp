#include "obm/core/point_cloud.hpp"

#include "obm/core/errors.hpp"

namespace obm {

void PointCloud::reserve(std::size_t n) {
  points.reserve(n);
  if (hasIntensity()) intensity.reserve(n);
  if (hasColors()) colors.reserve(n);
}

void PointCloud::clear() {
  points.clear();
  intensity.clear();
  colors.clear();
}

void PointCloud::push_back(const Vector3f& p, float i, const Color3u8& c) {
  const bool with_i = hasIntensity();
  points.push_back(p);
  if (with_i) intensity.push_back(i);
  if (hasColors()) colors.push_back(c);
}

void PointCloud::validate() const {
  if (!intensity.empty() && intensity.size() != points.size())
    throw ContractError("PointCloud: " + std::to_string(intensity.size()) + " intensities for " +
                        std::to_string(points.size()) + " points");
  if (!colors.empty() && colors.size() != points.size())
    throw ContractError("PointCloud: " + std::to_string(colors.size()) + " colours for " +
                        std::to_string(points.size()) + " points");
}

std::size_t PointCloud::removeNonFinite() {
  validate();
  std::size_t out = 0;
  for (std::size_t i = 0; i < points.size(); ++i) {
    if (!points[i].allFinite()) continue;
    points[out] = points[i];
    if (!intensity.empty()) intensity[out] = intensity[i];
    if (!colors.empty()) colors[out] = colors[i];
    ++out;
  }
  const std::size_t removed = points.size() - out;
  points.resize(out);
  if (!intensity.empty()) intensity.resize(out);
  if (!colors.empty()) colors.resize(out);
  return removed;
}

PointCloud PointCloud::transformed(const Eigen::Isometry3d& T_new_old,
                                   const std::string& new_frame) const {
  PointCloud out = *this;
  out.transform(T_new_old);
  out.frame_id = new_frame;
  return out;
}

void PointCloud::transform(const Eigen::Isometry3d& T_new_old) {
  const Eigen::Matrix3f R = T_new_old.linear().cast<float>();
  const Eigen::Vector3f t = T_new_old.translation().cast<float>();
  for (auto& p : points) p = R * p + t;
}

PointCloud PointCloud::select(const std::vector<std::size_t>& indices) const {
  validate();
  PointCloud out;
  out.timestamp = timestamp;
  out.frame_id = frame_id;
  out.points.reserve(indices.size());
  if (hasIntensity()) out.intensity.reserve(indices.size());
  if (hasColors()) out.colors.reserve(indices.size());
  for (std::size_t idx : indices) {
    OBM_ASSERT(idx < points.size(), "index out of range");
    out.points.push_back(points[idx]);
    if (hasIntensity()) out.intensity.push_back(intensity[idx]);
    if (hasColors()) out.colors.push_back(colors[idx]);
  }
  return out;
}

Eigen::Matrix3Xf PointCloud::matrix() const {
  Eigen::Matrix3Xf m(3, static_cast<Eigen::Index>(points.size()));
  for (std::size_t i = 0; i < points.size(); ++i) m.col(static_cast<Eigen::Index>(i)) = points[i];
  return m;
}

void PointCloud::bounds(Vector3f& min_pt, Vector3f& max_pt) const {
  if (points.empty()) {
    min_pt.setZero();
    max_pt.setZero();
    return;
  }
  min_pt = max_pt = points.front();
  for (const auto& p : points) {
    min_pt = min_pt.cwiseMin(p);
    max_pt = max_pt.cwiseMax(p);
  }
}

Vector3f PointCloud::centroid() const {
  if (points.empty()) return Vector3f::Zero();
  Eigen::Vector3d s = Eigen::Vector3d::Zero();
  for (const auto& p : points) s += p.cast<double>();
  return (s / static_cast<double>(points.size())).cast<float>();
}

}  // namespace obm
