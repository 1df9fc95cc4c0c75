#include "obm/frontend/descriptor.hpp"

#include <cmath>

namespace obm::frontend {

PlaceDescriptor computeDescriptor(const PointCloud& cloud, const DescriptorParams& params) {
  PlaceDescriptor d;
  d.bins = Eigen::MatrixXf::Zero(params.rings, params.sectors);
  const double ring_width = params.max_range / params.rings;
  const double sector_width = 2.0 * M_PI / params.sectors;
  for (const Vector3f& p : cloud.points) {
    if (!p.allFinite()) continue;
    const double r = std::hypot(static_cast<double>(p.x()), static_cast<double>(p.y()));
    if (r >= params.max_range) continue;
    const int ring = std::min(params.rings - 1, static_cast<int>(r / ring_width));
    const double az = std::atan2(static_cast<double>(p.y()), static_cast<double>(p.x())) + M_PI;
    const int sector = std::min(params.sectors - 1, static_cast<int>(az / sector_width));
    // Heights below the offset ground count as an occupied bin of height ~0 (a tiny positive
    // value), so that "something there" differs from "empty".
    const float h = std::max(1e-3f, p.z() + static_cast<float>(params.height_offset));
    float& bin = d.bins(ring, sector);
    bin = std::max(bin, h);
  }
  return d;
}

DescriptorMatch compareDescriptors(const PlaceDescriptor& a, const PlaceDescriptor& b) {
  DescriptorMatch best;
  best.distance = 1.0;
  if (a.empty() || b.empty() || a.bins.rows() != b.bins.rows() || a.bins.cols() != b.bins.cols())
    return best;
  const int sectors = static_cast<int>(a.bins.cols());
  const Eigen::VectorXf na = a.bins.colwise().norm();
  const Eigen::VectorXf nb = b.bins.colwise().norm();
  double best_d = 2.0;
  int best_shift = 0;
  for (int shift = 0; shift < sectors; ++shift) {
    double sum = 0.0;
    int n = 0;
    for (int c = 0; c < sectors; ++c) {
      const int cb = (c + shift) % sectors;
      if (na(c) <= 0.f || nb(cb) <= 0.f) continue;
      const double cosine = a.bins.col(c).dot(b.bins.col(cb)) / (na(c) * nb(cb));
      sum += 1.0 - cosine;
      ++n;
    }
    if (n == 0) continue;
    const double d = sum / n;
    if (d < best_d) {
      best_d = d;
      best_shift = shift;
    }
  }
  if (best_d > 1.0) return best;  // no common column
  best.distance = best_d;
  best.shift = best_shift;
  // Column c of `a` matches column c + shift of `b`: a point at azimuth φ in a is at φ + shift·Δ
  // in b, i.e. p_b = Rz(shift·Δ)·p_a and T_b_a has yaw shift·Δ.
  double yaw = best_shift * 2.0 * M_PI / sectors;
  if (yaw > M_PI) yaw -= 2.0 * M_PI;
  best.yaw = yaw;
  return best;
}

}  // namespace obm::frontend
