#pragma once
/// \file shape_error.hpp
/// The error of an object registration up to the object's symmetries (docs/metrics.md, "Surface
/// error"). RRE and RTE compare the estimate with the one pose that made the pair; a sphere
/// turned by any rotation, a cube by 90° or a cylinder about its axis is the same shape, and no
/// method that sees only shape can tell those poses apart. The surface error instead asks how
/// far the object, placed by the estimate, lies from the object placed by the truth.
#include <cstddef>
#include <cstdint>
#include <unordered_map>
#include <vector>

#include "obm/core/point_cloud.hpp"
#include "obm/core/se3.hpp"

namespace obm::eval {

/// Scores estimates of pairs cut from one object. Built once per object from a dense sample of
/// its surface in the frame of the pair's source (the object's own frame in generated pairs).
class SurfaceErrorScorer {
 public:
  /// `object`: surface samples (≥ 16 points); `normal_neighbours`: points (self included) of
  /// each sample's PCA normal. Throws ContractError for fewer than 16 points.
  explicit SurfaceErrorScorer(const PointCloud& object, int normal_neighbours = 10);

  /// Mean over the samples x of the distance of ΔT·x, ΔT = T_gt⁻¹·T_pred, from the surface:
  /// the distance to the tangent plane of its nearest sample y, |n_y·(ΔT·x − y)|, when y is
  /// within three median sample spacings (random samples leave holes of about two); else the
  /// distance to y itself (a point moved off the surface's extent), capped at cap(). 0 for
  /// T_pred = T_gt; near 0 for a symmetry of the shape. In the units of the cloud. The floor of
  /// a symmetry grows with the sample spacing (sharp edges tilt the normals near them): on 8192
  /// samples of a 1.8 × 1 × 0.6 box, 0.0007 for a 180° turn (2048 samples: 0.003).
  double error(const Isometry3d& T_pred, const Isometry3d& T_gt) const;

  /// Median distance between a sample and its nearest other sample.
  double spacing() const { return spacing_; }
  /// Largest per-point distance counted: the cell of the search grid (4 mean spacings).
  double cap() const { return cell_; }

 private:
  std::int64_t keyOf(const Vector3f& p) const;
  /// Samples in the 27 grid cells around p.
  void neighbours(const Vector3f& p, std::vector<std::size_t>& out) const;

  std::vector<Vector3f> points_, normals_;
  std::unordered_map<std::int64_t, std::vector<std::size_t>> grid_;
  float cell_ = 1.0f;
  double spacing_ = 0.0;
};

}  // namespace obm::eval
