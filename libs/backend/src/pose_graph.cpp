#include "obm/backend/pose_graph.hpp"

#include <cmath>

#include "obm/core/errors.hpp"

namespace obm::backend {

Pose3 Pose3::fromIsometry(const Isometry3d& T) {
  return Pose3(T.translation(), Eigen::Quaterniond(T.rotation()).normalized());
}

Isometry3d Pose3::isometry() const {
  return makeIsometry(q.normalized(), t);
}

std::vector<NodeId> PoseGraph::nodeIds() const {
  std::vector<NodeId> ids;
  ids.reserve(numNodes());
  if (is3D())
    for (const auto& kv : nodes3) ids.push_back(kv.first);
  else
    for (const auto& kv : nodes2) ids.push_back(kv.first);
  return ids;
}

Isometry3d PoseGraph::isometry(NodeId id) const {
  if (is3D()) {
    const auto it = nodes3.find(id);
    OBM_ASSERT(it != nodes3.end(), "node " + std::to_string(id) + " does not exist");
    return it->second.T_world_node.isometry();
  }
  const auto it = nodes2.find(id);
  OBM_ASSERT(it != nodes2.end(), "node " + std::to_string(id) + " does not exist");
  return it->second.T_world_node.toIsometry3d();
}

void PoseGraph::copyPosesFrom(const PoseGraph& other) {
  OBM_ASSERT(other.dimension == dimension, "graphs of different dimension");
  if (is3D()) {
    for (auto& [id, n] : nodes3) {
      const auto it = other.nodes3.find(id);
      if (it != other.nodes3.end()) n.T_world_node = it->second.T_world_node;
    }
  } else {
    for (auto& [id, n] : nodes2) {
      const auto it = other.nodes2.find(id);
      if (it != other.nodes2.end()) n.T_world_node = it->second.T_world_node;
    }
  }
}

void PoseGraph::validate() const {
  OBM_ASSERT(dimension == 2 || dimension == 3, "dimension must be 2 or 3");
  auto check = [&](std::size_t k, NodeId from, NodeId to, bool finite) {
    // The message is built only on failure: this runs before every optimisation.
    auto what = [&] {
      return "edge #" + std::to_string(k) + " (" + std::to_string(from) + " -> " +
             std::to_string(to) + ")";
    };
    if (!hasNode(from)) throw ContractError(what() + ": source node does not exist");
    if (!hasNode(to)) throw ContractError(what() + ": target node does not exist");
    if (from == to) throw ContractError(what() + ": joins a node to itself");
    if (!finite) throw ContractError(what() + ": non-finite measurement or information");
  };
  if (is3D()) {
    for (std::size_t k = 0; k < edges3.size(); ++k) {
      const auto& e = edges3[k];
      check(k, e.from, e.to,
            e.T_from_to.t.allFinite() && e.T_from_to.q.coeffs().allFinite() &&
                e.information.allFinite());
    }
    for (const auto& [id, n] : nodes3)
      if (!n.T_world_node.t.allFinite() || !n.T_world_node.q.coeffs().allFinite())
        throw ContractError("node " + std::to_string(id) + ": non-finite pose");
  } else {
    for (std::size_t k = 0; k < edges2.size(); ++k) {
      const auto& e = edges2[k];
      check(k, e.from, e.to,
            std::isfinite(e.T_from_to.x) && std::isfinite(e.T_from_to.y) &&
                std::isfinite(e.T_from_to.theta) && e.information.allFinite());
    }
    for (const auto& [id, n] : nodes2)
      if (!std::isfinite(n.T_world_node.x) || !std::isfinite(n.T_world_node.y) ||
          !std::isfinite(n.T_world_node.theta))
        throw ContractError("node " + std::to_string(id) + ": non-finite pose");
  }
  for (NodeId id : fixed)
    if (!hasNode(id)) throw ContractError("fixed node " + std::to_string(id) + " does not exist");
}

}  // namespace obm::backend
