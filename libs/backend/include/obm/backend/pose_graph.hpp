#pragma once
/// \file pose_graph.hpp
/// Plain data types of a pose graph: SE(3) or SE(2) nodes `T_world_node` and relative-pose edges
/// `T_from_to` with a full information matrix. No solver headers here: the optimizer (Ceres) lives
/// in src/ behind obm::backend::Optimizer.
#include <Eigen/Core>
#include <Eigen/Geometry>
#include <cstdint>
#include <map>
#include <optional>
#include <set>
#include <string>
#include <vector>

#include "obm/core/se3.hpp"

namespace obm::backend {

using NodeId = std::int64_t;
using Matrix6d = Eigen::Matrix<double, 6, 6>;

/// A rigid SE(3) pose stored as translation + quaternion exactly as given (a quaternion read from a
/// file is kept unnormalised, so that writing it back reproduces the file's numbers bit for bit).
struct Pose3 {
  Eigen::Vector3d t = Eigen::Vector3d::Zero();
  Eigen::Quaterniond q = Eigen::Quaterniond::Identity();  ///< normalised wherever it is used
  /// Roll, pitch, yaw [rad] as read from a TORO/MRPT `.graph` line. Kept only so that a `.graph`
  /// written back repeats the file's angles bit for bit; used by the writer only while `q` still
  /// equals the quaternion made from these angles (i.e. the pose has not been changed since).
  std::optional<Eigen::Vector3d> rpy_from_file;

  Pose3() = default;
  Pose3(const Eigen::Vector3d& t_, const Eigen::Quaterniond& q_) : t(t_), q(q_) {}
  /// From an isometry (rotation converted to a unit quaternion).
  static Pose3 fromIsometry(const Isometry3d& T);
  /// As an isometry (quaternion normalised).
  Isometry3d isometry() const;
  /// Unit quaternion of this pose.
  Eigen::Quaterniond unitQuaternion() const { return q.normalized(); }
};

/// Robust loss applied to one edge's χ² term.
enum class LossKind {
  Default,  ///< use the optimizer's per-kind default (Options::loop_loss for loop edges)
  None,     ///< plain least squares
  Huber,    ///< Huber on the χ² term, scale = δ (same unit as √χ²)
  Cauchy,   ///< Cauchy (Lorentzian) on the χ² term, scale = c
  Dcs,      ///< dynamic covariance scaling (outlier-robust mode), scale = Φ (χ² units)
};

/// Loss of an edge: kind and scale (δ for Huber, c for Cauchy in √χ² units; Φ for DCS in χ² units).
struct EdgeLoss {
  LossKind kind = LossKind::Default;
  double scale = 1.0;
};

/// A 3D node: the pose of the node frame in the world frame.
struct Node3 {
  NodeId id = 0;
  Pose3 T_world_node;
};

/// A 2D node (x, y, θ); θ is kept as given (not wrapped) so files round-trip exactly.
struct Node2 {
  NodeId id = 0;
  Pose2 T_world_node;
};

/// A 3D relative-pose measurement Z = T_from_to with its 6×6 information matrix Ω over the g2o
/// error [t; vec(q)] (translation first, then the quaternion's vector part).
struct Edge3 {
  NodeId from = 0;
  NodeId to = 0;
  Pose3 T_from_to;
  Matrix6d information = Matrix6d::Identity();
  EdgeLoss loss;
  bool is_loop = false;  ///< a loop closure (robust modes act only on these)
};

/// A 2D relative-pose measurement Z = T_from_to with its 3×3 information matrix Ω over the g2o
/// error [x; y; θ].
struct Edge2 {
  NodeId from = 0;
  NodeId to = 0;
  Pose2 T_from_to;
  Eigen::Matrix3d information = Eigen::Matrix3d::Identity();
  EdgeLoss loss;
  bool is_loop = false;
};

/// The graph: either 3D (nodes3/edges3) or 2D (nodes2/edges2) according to `dimension`.
struct PoseGraph {
  int dimension = 3;               ///< 3 (SE(3)) or 2 (SE(2))
  std::map<NodeId, Node3> nodes3;  ///< by id (3D graphs)
  std::vector<Edge3> edges3;       ///< in file order (3D graphs)
  std::map<NodeId, Node2> nodes2;  ///< by id (2D graphs)
  std::vector<Edge2> edges2;       ///< in file order (2D graphs)
  std::set<NodeId> fixed;          ///< nodes held constant (g2o `FIX` lines)

  bool is3D() const { return dimension == 3; }
  std::size_t numNodes() const { return is3D() ? nodes3.size() : nodes2.size(); }
  std::size_t numEdges() const { return is3D() ? edges3.size() : edges2.size(); }
  bool hasNode(NodeId id) const { return is3D() ? nodes3.count(id) > 0 : nodes2.count(id) > 0; }
  /// Ids of all nodes in increasing order.
  std::vector<NodeId> nodeIds() const;
  /// Pose of a node as an SE(3) isometry (2D poses lifted with z = 0); throws ContractError if
  /// absent.
  Isometry3d isometry(NodeId id) const;
  /// Copies the poses of `other` (same dimension) into this graph's nodes of the same ids.
  void copyPosesFrom(const PoseGraph& other);
  /// Checks that every edge joins two existing nodes, no edge is a self-loop and every number is
  /// finite; throws ContractError naming the first offending edge.
  void validate() const;
};

/// The default loop flag of an edge between `from` and `to`: any edge that does not join
/// consecutive ids (|to − from| ≠ 1) is a loop closure; odometry edges join consecutive ids.
inline bool isLoopByIds(NodeId from, NodeId to) {
  return !(to - from == 1 || from - to == 1);
}

}  // namespace obm::backend
