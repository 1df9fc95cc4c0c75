#pragma once
/// \file metrics.hpp
/// g2o's χ² (the cost the optimizer minimises) and the absolute trajectory error against a
/// reference.
#include "obm/backend/pose_graph.hpp"

namespace obm::backend {

using Vector6d = Eigen::Matrix<double, 6, 1>;

/// g2o's EdgeSE3 error of a measurement Z between poses X_a, X_b:
/// Δ = Z⁻¹·(X_a⁻¹·X_b), e = [t(Δ); vec(q(Δ))] with the sign of q(Δ) chosen so that w ≥ 0.
Vector6d edgeError(const Pose3& Z, const Pose3& X_a, const Pose3& X_b);

/// g2o's EdgeSE2 error: e = [R(θ_Z)ᵀ(t_ab − t_Z); wrap(θ_ab − θ_Z)], (t_ab, θ_ab) = X_a⁻¹·X_b.
Eigen::Vector3d edgeError(const Pose2& Z, const Pose2& X_a, const Pose2& X_b);

/// eᵀΩe of one edge at the graph's current poses.
double edgeChi2(const PoseGraph& graph, const Edge3& edge);
double edgeChi2(const PoseGraph& graph, const Edge2& edge);

/// g2o's χ² of the graph: Σ eᵀΩe over all edges (no robust kernel).
double chi2(const PoseGraph& graph);

/// Absolute trajectory error: RMSE / mean / max of the translation differences between `estimate`
/// and `reference` over their common node ids, after the rigid (no scale) least-squares alignment
/// of the estimate onto the reference (Horn/Umeyama, closed form) when `align` is true.
struct AteResult {
  double rmse = 0.0;  ///< [m]
  double mean = 0.0;  ///< [m]
  double max = 0.0;   ///< [m]
  std::size_t count = 0;
};
AteResult absoluteTrajectoryError(const PoseGraph& estimate, const PoseGraph& reference,
                                  bool align = true);

}  // namespace obm::backend
