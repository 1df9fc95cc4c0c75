#include "obm/core/ransac_pose.hpp"

#include <Eigen/SVD>
#include <algorithm>
#include <cmath>
#include <random>
#include <string>

#include "obm/core/errors.hpp"

namespace obm {

Isometry3d fitRigidPose(const std::vector<Eigen::Vector3d>& source,
                        const std::vector<Eigen::Vector3d>& target,
                        const std::vector<std::size_t>& idx, bool planar,
                        const std::vector<double>& weights) {
  double wsum = 0.0;
  Eigen::Vector3d xs = Eigen::Vector3d::Zero(), ys = Eigen::Vector3d::Zero();
  for (const auto i : idx) {
    const double w = weights.empty() ? 1.0 : weights[i];
    wsum += w;
    xs += w * source[i];
    ys += w * target[i];
  }
  if (!(wsum > 0.0)) return Isometry3d::Identity();
  const Eigen::Vector3d x_bar = xs / wsum, y_bar = ys / wsum;
  Eigen::Matrix3d R = Eigen::Matrix3d::Identity();
  if (planar) {
    // Yaw maximising Σ w (a·Rb) in the plane: θ = atan2(Σ w (a × b)_z, Σ w a·b).
    double s = 0.0, c = 0.0;
    for (const auto i : idx) {
      const double w = weights.empty() ? 1.0 : weights[i];
      const Eigen::Vector3d a = source[i] - x_bar, b = target[i] - y_bar;
      s += w * (a.x() * b.y() - a.y() * b.x());
      c += w * (a.x() * b.x() + a.y() * b.y());
    }
    R = Eigen::AngleAxisd(std::atan2(s, c), Eigen::Vector3d::UnitZ()).toRotationMatrix();
  } else {
    Eigen::Matrix3d S = Eigen::Matrix3d::Zero();  // Σ w (y − ȳ)(x − x̄)ᵀ
    for (const auto i : idx) {
      const double w = weights.empty() ? 1.0 : weights[i];
      S += w * (target[i] - y_bar) * (source[i] - x_bar).transpose();
    }
    Eigen::JacobiSVD<Eigen::Matrix3d> svd(S, Eigen::ComputeFullU | Eigen::ComputeFullV);
    Eigen::Matrix3d D = Eigen::Matrix3d::Identity();
    if ((svd.matrixU() * svd.matrixV().transpose()).determinant() < 0.0) D(2, 2) = -1.0;
    R = svd.matrixU() * D * svd.matrixV().transpose();
  }
  return makeIsometry(R, y_bar - R * x_bar);
}

namespace {

std::vector<std::size_t> consensus(const std::vector<Eigen::Vector3d>& source,
                                   const std::vector<Eigen::Vector3d>& target,
                                   const Isometry3d& T, double threshold2) {
  std::vector<std::size_t> in;
  for (std::size_t i = 0; i < source.size(); ++i)
    if ((T * source[i] - target[i]).squaredNorm() <= threshold2) in.push_back(i);
  return in;
}

}  // namespace

RansacPoseResult ransacPose(const std::vector<Eigen::Vector3d>& source,
                            const std::vector<Eigen::Vector3d>& target,
                            const RansacPoseParams& params, const std::vector<double>& weights) {
  if (source.size() != target.size())
    throw ContractError("ransacPose: " + std::to_string(source.size()) + " source points but " +
                        std::to_string(target.size()) + " target points");
  if (!weights.empty() && weights.size() != source.size())
    throw ContractError("ransacPose: " + std::to_string(weights.size()) + " weights for " +
                        std::to_string(source.size()) + " pairs");
  if (!(params.inlier_threshold > 0.0) || params.iterations < 1 || params.refinements < 0)
    throw ContractError(
        "ransacPose: inlier_threshold must be > 0, iterations >= 1, refinements >= 0");
  RansacPoseResult best;
  const std::size_t m = params.planar ? 2 : 3;
  const std::size_t n = source.size();
  if (n < m) return best;
  const double thr = params.inlier_threshold, thr2 = thr * thr;
  std::mt19937_64 rng(params.seed);
  std::uniform_int_distribution<std::size_t> pick(0, n - 1);
  std::vector<std::size_t> sample(m);
  const bool grouped = !params.group.empty();
  if (grouped && params.group.size() != n)
    throw ContractError("ransacPose: " + std::to_string(params.group.size()) + " group labels for " +
                        std::to_string(n) + " pairs");
  std::size_t n_groups = 0;
  for (const auto g : params.group) n_groups = std::max(n_groups, g + 1);
  std::vector<std::uint32_t> seen(n_groups, 0);  // stamp of the last pose that counted a group
  std::uint32_t stamp = 0;
  for (int it = 0; it < params.iterations; ++it) {
    for (std::size_t k = 0; k < m; ++k) sample[k] = pick(rng);
    bool usable = true;
    for (std::size_t a = 0; a < m && usable; ++a)
      for (std::size_t b = a + 1; b < m && usable; ++b) {
        if (sample[a] == sample[b]) {
          usable = false;
          break;
        }
        const double ds = (source[sample[a]] - source[sample[b]]).norm();
        const double dt = (target[sample[a]] - target[sample[b]]).norm();
        // Pairs closer than the threshold fix no rotation.
        if (ds < 2.0 * thr) usable = false;
        if (params.check_lengths && std::abs(ds - dt) > thr) usable = false;
      }
    if (!usable) continue;
    const Isometry3d T = fitRigidPose(source, target, sample, params.planar);
    if (params.planar && std::abs(std::atan2(T.linear()(1, 0), T.linear()(0, 0))) > params.max_yaw)
      continue;
    std::size_t count = 0;
    if (grouped) {
      ++stamp;
      for (std::size_t i = 0; i < n; ++i)
        if (seen[params.group[i]] != stamp && (T * source[i] - target[i]).squaredNorm() <= thr2) {
          seen[params.group[i]] = stamp;
          ++count;
        }
    } else {
      for (std::size_t i = 0; i < n; ++i)
        if ((T * source[i] - target[i]).squaredNorm() <= thr2) ++count;
    }
    if (count > best.inliers) {
      best.inliers = count;
      best.T_target_source = T;
      best.ok = true;
    }
  }
  if (!best.ok) return best;
  best.inlier = consensus(source, target, best.T_target_source, thr2);
  for (int r = 0; r < params.refinements && best.inlier.size() >= m; ++r) {
    const Isometry3d T = fitRigidPose(source, target, best.inlier, params.planar, weights);
    auto in = consensus(source, target, T, thr2);
    if (in.size() < best.inlier.size()) break;  // least squares may only keep or grow the set
    best.T_target_source = T;
    best.inlier = std::move(in);
  }
  if (grouped) {
    std::vector<bool> counted(n_groups, false);
    best.inliers = 0;
    for (const auto i : best.inlier)
      if (!counted[params.group[i]]) {
        counted[params.group[i]] = true;
        ++best.inliers;
      }
  } else {
    best.inliers = best.inlier.size();
  }
  return best;
}

}  // namespace obm
