#pragma once
/// \file point_cloud.hpp
/// The one point-cloud type passed between libraries: float xyz in a named frame, with optional
/// per-point intensity and RGB colour, and the acquisition time.
#include <Eigen/Core>
#include <Eigen/Geometry>
#include <cstdint>
#include <string>
#include <vector>

namespace obm {

using Vector3f = Eigen::Vector3f;
using Color3u8 = Eigen::Matrix<std::uint8_t, 3, 1>;

struct PointCloud {
  std::vector<Vector3f> points;     ///< [m] xyz in frame `frame_id`
  std::vector<float> intensity;     ///< empty, or one value per point (sensor units)
  std::vector<Color3u8> colors;     ///< empty, or one RGB per point
  double timestamp = 0.0;           ///< [s] acquisition time (UNIX or sequence time)
  std::string frame_id = "sensor";  ///< frame the points are expressed in

  std::size_t size() const noexcept { return points.size(); }
  bool empty() const noexcept { return points.empty(); }
  bool hasIntensity() const noexcept { return !intensity.empty(); }
  bool hasColors() const noexcept { return !colors.empty(); }
  void reserve(std::size_t n);
  void clear();

  /// Append a point (intensity / colour only when this cloud carries them).
  void push_back(const Vector3f& p, float i = 0.f, const Color3u8& c = Color3u8::Zero());

  /// Checks that attribute arrays are empty or sized like `points`; throws ContractError if not.
  void validate() const;

  /// Removes points with a NaN or infinite coordinate (and their attributes); returns how many.
  std::size_t removeNonFinite();

  /// Returns the points transformed by `T_new_frame` (p_new = T·p); attributes copied.
  PointCloud transformed(const Eigen::Isometry3d& T_new_old, const std::string& new_frame) const;

  /// In-place transform.
  void transform(const Eigen::Isometry3d& T_new_old);

  /// Returns the subset at `indices` (attributes kept).
  PointCloud select(const std::vector<std::size_t>& indices) const;

  /// Points as a 3×N float matrix (column i = point i).
  Eigen::Matrix3Xf matrix() const;

  /// Axis-aligned bounds; both zero when empty.
  void bounds(Vector3f& min_pt, Vector3f& max_pt) const;

  /// Centroid; zero when empty.
  Vector3f centroid() const;
};

}  // namespace obm
