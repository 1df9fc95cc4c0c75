#include "obm/backend/metrics.hpp"

#include <Eigen/SVD>
#include <cmath>

#include "obm/core/errors.hpp"

namespace obm::backend {

Vector6d edgeError(const Pose3& Z, const Pose3& X_a, const Pose3& X_b) {
  const Eigen::Quaterniond qa = X_a.q.normalized(), qb = X_b.q.normalized(), qz = Z.q.normalized();
  // X_ab = X_a⁻¹·X_b, Δ = Z⁻¹·X_ab (g2o EdgeSE3::computeError).
  const Eigen::Quaterniond q_ab = qa.conjugate() * qb;
  const Eigen::Vector3d t_ab = qa.conjugate() * (X_b.t - X_a.t);
  Eigen::Quaterniond q_d = qz.conjugate() * q_ab;
  const Eigen::Vector3d t_d = qz.conjugate() * (t_ab - Z.t);
  if (q_d.w() < 0.0) q_d.coeffs() = -q_d.coeffs();  // g2o's toVectorMQT: w ≥ 0
  Vector6d e;
  e << t_d, q_d.vec();
  return e;
}

Eigen::Vector3d edgeError(const Pose2& Z, const Pose2& X_a, const Pose2& X_b) {
  const double ca = std::cos(X_a.theta), sa = std::sin(X_a.theta);
  const double dx = X_b.x - X_a.x, dy = X_b.y - X_a.y;
  const double tx = ca * dx + sa * dy, ty = -sa * dx + ca * dy;  // t_ab = R_aᵀ(t_b − t_a)
  const double cz = std::cos(Z.theta), sz = std::sin(Z.theta);
  const double ex = tx - Z.x, ey = ty - Z.y;
  return {cz * ex + sz * ey, -sz * ex + cz * ey, wrapAngle(X_b.theta - X_a.theta - Z.theta)};
}

double edgeChi2(const PoseGraph& g, const Edge3& e) {
  const Vector6d r =
      edgeError(e.T_from_to, g.nodes3.at(e.from).T_world_node, g.nodes3.at(e.to).T_world_node);
  return r.dot(e.information * r);
}

double edgeChi2(const PoseGraph& g, const Edge2& e) {
  const Eigen::Vector3d r =
      edgeError(e.T_from_to, g.nodes2.at(e.from).T_world_node, g.nodes2.at(e.to).T_world_node);
  return r.dot(e.information * r);
}

double chi2(const PoseGraph& g) {
  double s = 0.0;
  if (g.is3D())
    for (const auto& e : g.edges3) s += edgeChi2(g, e);
  else
    for (const auto& e : g.edges2) s += edgeChi2(g, e);
  return s;
}

AteResult absoluteTrajectoryError(const PoseGraph& est, const PoseGraph& ref, bool align) {
  std::vector<Eigen::Vector3d> a, b;
  for (NodeId id : est.nodeIds())
    if (ref.hasNode(id)) {
      a.push_back(est.isometry(id).translation());
      b.push_back(ref.isometry(id).translation());
    }
  AteResult r;
  r.count = a.size();
  if (a.empty()) return r;
  Eigen::Matrix3d R = Eigen::Matrix3d::Identity();
  Eigen::Vector3d t = Eigen::Vector3d::Zero();
  if (align && a.size() >= 2) {
    // Closed-form rigid alignment b ≈ R·a + t (Umeyama 1991, without scale).
    Eigen::Vector3d ma = Eigen::Vector3d::Zero(), mb = Eigen::Vector3d::Zero();
    for (std::size_t i = 0; i < a.size(); ++i) {
      ma += a[i];
      mb += b[i];
    }
    ma /= double(a.size());
    mb /= double(a.size());
    Eigen::Matrix3d C = Eigen::Matrix3d::Zero();
    for (std::size_t i = 0; i < a.size(); ++i) C += (b[i] - mb) * (a[i] - ma).transpose();
    Eigen::JacobiSVD<Eigen::Matrix3d> svd(C, Eigen::ComputeFullU | Eigen::ComputeFullV);
    Eigen::Matrix3d S = Eigen::Matrix3d::Identity();
    if ((svd.matrixU() * svd.matrixV().transpose()).determinant() < 0) S(2, 2) = -1;
    R = svd.matrixU() * S * svd.matrixV().transpose();
    t = mb - R * ma;
  }
  double sum2 = 0.0, sum = 0.0;
  for (std::size_t i = 0; i < a.size(); ++i) {
    const double d = (R * a[i] + t - b[i]).norm();
    sum2 += d * d;
    sum += d;
    r.max = std::max(r.max, d);
  }
  r.rmse = std::sqrt(sum2 / double(a.size()));
  r.mean = sum / double(a.size());
  return r;
}

}  // namespace obm::backend
