// The Ceres pose_graph_3d / pose_graph_2d examples' formulation (see peers.hpp), written for this
// benchmark from the examples' description.
#include <ceres/ceres.h>

#include <Eigen/Cholesky>
#include <cmath>
#include <deque>
#include <unordered_map>

#include "obm/backend/blas_threads.hpp"
#include "obm/core/timer.hpp"
#include "peers.hpp"

namespace obm::bench {
namespace {

using backend::Matrix6d;

/// 3D: r = L·[R_aᵀ(t_b − t_a) − t_ab;  2·vec(q_ab ⊗ (q_a* ⊗ q_b)*)],  Ω = L·Lᵀ.
struct Example3dResidual {
  Example3dResidual(const Eigen::Vector3d& t_ab, const Eigen::Quaterniond& q_ab, const Matrix6d& L)
      : t_ab(t_ab), q_ab(q_ab.normalized()), L(L) {}
  template <typename T>
  bool operator()(const T* ta, const T* qa, const T* tb, const T* qb, T* out) const {
    using V3 = Eigen::Matrix<T, 3, 1>;
    using Q = Eigen::Quaternion<T>;
    const Eigen::Map<const V3> p_a(ta), p_b(tb);
    const Eigen::Map<const Q> q_a(qa), q_b(qb);
    const Q q_a_inv = q_a.conjugate();
    const Q q_ab_est = q_a_inv * q_b;
    const V3 p_ab_est = q_a_inv * (p_b - p_a);
    const Q dq = q_ab.template cast<T>() * q_ab_est.conjugate();
    Eigen::Map<Eigen::Matrix<T, 6, 1>> r(out);
    r.template head<3>() = p_ab_est - t_ab.template cast<T>();
    r.template tail<3>() = T(2.0) * dq.vec();
    r.applyOnTheLeft(L.template cast<T>());
    return true;
  }
  Eigen::Vector3d t_ab;
  Eigen::Quaterniond q_ab;
  Matrix6d L;
};

template <typename T>
T normalizeAngle(const T& a) {
  const T two_pi(2.0 * M_PI);
  return a - two_pi * ceres::floor((a + T(M_PI)) / two_pi);
}

/// 2D: r = L·[R(θ_a)ᵀ(t_b − t_a) − t_ab;  normalise(θ_b − θ_a − θ_ab)].
struct Example2dResidual {
  Example2dResidual(double x, double y, double th, const Eigen::Matrix3d& L)
      : x(x), y(y), th(th), L(L) {}
  template <typename T>
  bool operator()(const T* xa, const T* ya, const T* tha, const T* xb, const T* yb, const T* thb,
                  T* out) const {
    const T c = ceres::cos(*tha), s = ceres::sin(*tha);
    const T dx = *xb - *xa, dy = *yb - *ya;
    Eigen::Matrix<T, 3, 1> r;
    r << c * dx + s * dy - T(x), -s * dx + c * dy - T(y), normalizeAngle(*thb - *tha - T(th));
    Eigen::Map<Eigen::Matrix<T, 3, 1>> res(out);
    res = L.template cast<T>() * r;
    return true;
  }
  double x, y, th;
  Eigen::Matrix3d L;
};

struct AnglePlus {
  template <typename T>
  bool Plus(const T* x, const T* delta, T* out) const {
    *out = normalizeAngle(*x + *delta);
    return true;
  }
  template <typename T>
  bool Minus(const T* y, const T* x, T* out) const {
    *out = normalizeAngle(*y - *x);
    return true;
  }
};

}  // namespace

PeerResult solveCeresExample(const backend::PoseGraph& graph) {
  PeerResult res;
  res.solution = graph;
  // The same BLAS threading as obm-graph's optimizer (blas_threads.hpp), so that the comparison
  // measures the formulations and solver settings, not OpenMP spin-waits.
  const backend::ScopedSingleThreadedBlas one_blas_thread;
  Timer timer;
  ceres::Problem problem;
  ceres::Solver::Options options;
  options.linear_solver_type = ceres::SPARSE_NORMAL_CHOLESKY;
  if (graph.is3D()) {
    struct Block {
      Eigen::Vector3d p;
      Eigen::Quaterniond q;
    };
    std::unordered_map<backend::NodeId, Block> poses;
    for (const auto& [id, n] : graph.nodes3)
      poses[id] = Block{n.T_world_node.t, n.T_world_node.q.normalized()};
    ceres::Manifold* quaternion_manifold = new ceres::EigenQuaternionManifold;
    for (const auto& e : graph.edges3) {
      const Matrix6d L = e.information.llt().matrixL();
      auto* cost = new ceres::AutoDiffCostFunction<Example3dResidual, 6, 3, 4, 3, 4>(
          new Example3dResidual(e.T_from_to.t, e.T_from_to.q, L));
      Block& a = poses.at(e.from);
      Block& b = poses.at(e.to);
      problem.AddResidualBlock(cost, nullptr, a.p.data(), a.q.coeffs().data(), b.p.data(),
                               b.q.coeffs().data());
      problem.SetManifold(a.q.coeffs().data(), quaternion_manifold);
      problem.SetManifold(b.q.coeffs().data(), quaternion_manifold);
    }
    Block& first = poses.at(graph.nodes3.begin()->first);
    if (problem.HasParameterBlock(first.p.data())) {
      problem.SetParameterBlockConstant(first.p.data());
      problem.SetParameterBlockConstant(first.q.coeffs().data());
    }
    options.max_num_iterations = 200;
    ceres::Solver::Summary summary;
    ceres::Solve(options, &problem, &summary);
    res.time_s = timer.seconds();
    res.iterations = summary.num_successful_steps + summary.num_unsuccessful_steps;
    res.ok = summary.IsSolutionUsable();
    res.note = ceres::TerminationTypeToString(summary.termination_type);
    for (auto& [id, n] : res.solution.nodes3) {
      const Block& b = poses.at(id);
      n.T_world_node = backend::Pose3(b.p, b.q.normalized());
    }
  } else {
    std::unordered_map<backend::NodeId, std::array<double, 3>> poses;
    for (const auto& [id, n] : graph.nodes2)
      poses[id] = {n.T_world_node.x, n.T_world_node.y, n.T_world_node.theta};
    ceres::Manifold* angle_manifold = new ceres::AutoDiffManifold<AnglePlus, 1, 1>;
    for (const auto& e : graph.edges2) {
      const Eigen::Matrix3d L = e.information.llt().matrixL();
      auto* cost = new ceres::AutoDiffCostFunction<Example2dResidual, 3, 1, 1, 1, 1, 1, 1>(
          new Example2dResidual(e.T_from_to.x, e.T_from_to.y, e.T_from_to.theta, L));
      auto& a = poses.at(e.from);
      auto& b = poses.at(e.to);
      problem.AddResidualBlock(cost, nullptr, &a[0], &a[1], &a[2], &b[0], &b[1], &b[2]);
      problem.SetManifold(&a[2], angle_manifold);
      problem.SetManifold(&b[2], angle_manifold);
    }
    auto& first = poses.at(graph.nodes2.begin()->first);
    if (problem.HasParameterBlock(&first[0]))
      for (int k = 0; k < 3; ++k) problem.SetParameterBlockConstant(&first[k]);
    options.max_num_iterations = 100;
    ceres::Solver::Summary summary;
    ceres::Solve(options, &problem, &summary);
    res.time_s = timer.seconds();
    res.iterations = summary.num_successful_steps + summary.num_unsuccessful_steps;
    res.ok = summary.IsSolutionUsable();
    res.note = ceres::TerminationTypeToString(summary.termination_type);
    for (auto& [id, n] : res.solution.nodes2) {
      const auto& p = poses.at(id);
      n.T_world_node = Pose2(p[0], p[1], p[2]);
    }
  }
  return res;
}

}  // namespace obm::bench
