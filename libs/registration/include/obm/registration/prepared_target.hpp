#pragma once
/// \file prepared_target.hpp
/// A target cloud made ready for repeated registration: optional voxel down-sampling, a KD-tree
/// (nanoflann, kept out of this header) and PCA surface normals. Building it is the expensive part
/// of point-to-plane ICP, so the mapping front-end builds one per local map / keyframe and matches
/// many sources against it. Immutable after construction: safe to share between threads.
#include <cstddef>
#include <cstdint>
#include <memory>
#include <vector>

#include "obm/core/point_cloud.hpp"

namespace obm {
class ConfigNode;
}  // namespace obm

namespace obm::registration {

/// How a PreparedTarget is built (also PreparedTarget::Options).
struct PreparedTargetOptions {
  double voxel = 0.0;         ///< [m] voxel-grid down-sampling edge; 0 = keep every point
  int normal_neighbors = 15;  ///< k nearest neighbours (self included) of the PCA normal
  /// A normal is trusted when the neighbourhood is planar: (λ₁ − λ₀)/λ₂ >= this, with
  /// λ₀ <= λ₁ <= λ₂ the covariance eigenvalues (0 for lines and isotropic blobs, 1 for a disc).
  double min_planarity = 0.05;
  int threads = 2;  ///< threads of the normal estimation
  /// Also estimate, where the cloud has colours and the normal is trusted, the gradient of the
  /// colour intensity on the tangent plane (coloured ICP's photometric term, docs/registration.md
  /// "Coloured ICP"): d_p minimises Σ_q (I(p) + d_pᵀ(q' − p) − I(q))² over the k neighbours q,
  /// q' = q projected on p's tangent plane, with d_pᵀ n_p = 0.
  bool color_gradients = false;
};

/// Grey level in [0, 1] of an RGB colour (ITU-R BT.601 luma), the photometric term's intensity.
inline float colorIntensity(const Color3u8& c) {
  return (0.299f * float(c[0]) + 0.587f * float(c[1]) + 0.114f * float(c[2])) / 255.f;
}

/// A cloud's surface as PreparedTarget estimates it, per point: the normal, whether it is trusted
/// and the colour gradient. For callers that estimate it once per piece of a map and merge the
/// pieces (the front-end's local map with LocalMapParams::keyframe_normals).
struct SurfaceAttributes {
  std::vector<Vector3f> normals;     ///< unit normals (see PreparedTarget::normals)
  std::vector<std::uint8_t> valid;   ///< see PreparedTarget::normalValid
  std::vector<Vector3f> gradients;   ///< empty, or see PreparedTarget::colorGradients
};

class PreparedTarget {
 public:
  using Options = PreparedTargetOptions;

  /// Removes non-finite points, down-samples, builds the KD-tree and the normals. Throws
  /// ContractError for options out of range (normal_neighbors < 3, threads < 1, voxel < 0).
  explicit PreparedTarget(const PointCloud& target, const Options& options = Options());
  /// Takes the surface as given instead of estimating it: builds the KD-tree only (and the
  /// intensities, when `surface` has gradients and the cloud colours). `target` must be finite and
  /// every attribute sized like it (ContractError otherwise); Options::voxel must be 0.
  PreparedTarget(PointCloud target, SurfaceAttributes surface, const Options& options);
  ~PreparedTarget();
  PreparedTarget(PreparedTarget&&) noexcept;
  PreparedTarget& operator=(PreparedTarget&&) noexcept;
  PreparedTarget(const PreparedTarget&) = delete;
  PreparedTarget& operator=(const PreparedTarget&) = delete;

  /// The (down-sampled, finite) target points the tree indexes.
  const PointCloud& cloud() const;
  std::size_t size() const;
  bool empty() const;
  /// Unit normal per point, oriented towards the frame origin (the sensor); meaningful only where
  /// normalValid() is 1.
  const std::vector<Vector3f>& normals() const;
  /// 1 where the neighbourhood was planar enough for a point-to-plane residual, else 0.
  const std::vector<std::uint8_t>& normalValid() const;
  /// normals(), normalValid() and colorGradients() together (copies).
  SurfaceAttributes surface() const;
  const Options& options() const;

  /// True when colour gradients were estimated (Options::color_gradients and a coloured cloud).
  bool hasColorGradients() const;
  /// Intensity per point (colorIntensity); empty unless hasColorGradients().
  const std::vector<float>& intensity() const;
  /// Tangent-plane intensity gradient d_p [1/m] per point; zero where the normal is not trusted;
  /// empty unless hasColorGradients().
  const std::vector<Vector3f>& colorGradients() const;
  /// Coloured ICP's photometric residual for a source point of intensity `source_intensity` that
  /// lands at `x` (target frame) paired with target point `j`: I(q_j) + d_jᵀ(x − q_j) − I_source,
  /// the colour the target's tangent plane predicts at x minus the source's. Needs
  /// hasColorGradients(); its Jacobian in x is d_j (colorGradients()[j]).
  double colorResidual(std::size_t j, const Eigen::Vector3d& x, float source_intensity) const;

  /// Nearest target point to `query` within `max_distance` [m]: its index and squared distance.
  /// Returns false when there is none that close.
  bool nearest(const Vector3f& query, double max_distance, std::size_t& index,
               float& distance2) const;

  /// The (up to) k nearest target points, sorted by distance; returns how many were found.
  std::size_t knn(const Vector3f& query, std::size_t k, std::vector<std::size_t>& indices,
                  std::vector<float>& distances2) const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace obm::registration
