#include "obm/registration/prepared_target.hpp"

#include <Eigen/Eigenvalues>
#include <cmath>
#include <limits>
#include <nanoflann.hpp>

#include "obm/core/cloud_ops.hpp"
#include "obm/core/errors.hpp"
#include "obm/core/parallel.hpp"

namespace obm::registration {
namespace {

/// nanoflann's dataset adaptor over the prepared cloud's points.
struct PointsAdaptor {
  const std::vector<Vector3f>* pts = nullptr;
  std::size_t kdtree_get_point_count() const { return pts->size(); }
  float kdtree_get_pt(std::size_t i, std::size_t dim) const { return (*pts)[i][int(dim)]; }
  template <class BBox>
  bool kdtree_get_bbox(BBox&) const {
    return false;
  }
};

using KdTree =
    nanoflann::KDTreeSingleIndexAdaptor<nanoflann::L2_Simple_Adaptor<float, PointsAdaptor>,
                                        PointsAdaptor, 3, std::size_t>;

/// Result set for "the nearest point within r": starts with worstDist = r² so the tree prunes
/// every branch farther than the gate (much cheaper than an unbounded 1-NN for far points).
class NearestWithin {
 public:
  using DistanceType = float;
  using IndexType = std::size_t;
  explicit NearestWithin(float radius2) : dist_(radius2) {}
  std::size_t size() const { return found_ ? 1 : 0; }
  bool full() const { return found_; }
  bool addPoint(float d, std::size_t i) {
    // Ties are broken by the lower index so the answer does not depend on the visiting order.
    if (d < dist_ || (found_ && d == dist_ && i < index_)) {
      dist_ = d;
      index_ = i;
      found_ = true;
    }
    return true;
  }
  float worstDist() const { return dist_; }
  std::size_t index() const { return index_; }
  bool found() const { return found_; }

 private:
  float dist_;
  std::size_t index_ = 0;
  bool found_ = false;
};

}  // namespace

struct PreparedTarget::Impl {
  Options options;
  PointCloud cloud;
  std::vector<Vector3f> normals;
  std::vector<std::uint8_t> valid;
  std::vector<float> intensity;       // colour intensity (only with colour gradients)
  std::vector<Vector3f> gradients;    // tangent-plane intensity gradients (idem)
  PointsAdaptor adaptor;
  std::unique_ptr<KdTree> tree;
};

PreparedTarget::PreparedTarget(const PointCloud& target, const Options& options)
    : impl_(std::make_unique<Impl>()) {
  OBM_ASSERT(options.normal_neighbors >= 3, "PreparedTarget: normal_neighbors must be >= 3");
  OBM_ASSERT(options.threads >= 1, "PreparedTarget: threads must be >= 1");
  OBM_ASSERT(options.voxel >= 0.0 && std::isfinite(options.voxel),
             "PreparedTarget: voxel must be >= 0");
  auto& d = *impl_;
  d.options = options;
  d.cloud = target;
  d.cloud.removeNonFinite();
  if (options.voxel > 0.0) d.cloud = voxelDownsample(d.cloud, options.voxel);
  d.adaptor.pts = &d.cloud.points;
  const std::size_t n = d.cloud.size();
  d.normals.assign(n, Vector3f::Zero());
  d.valid.assign(n, 0);
  if (n == 0) return;
  d.tree = std::make_unique<KdTree>(3, d.adaptor, nanoflann::KDTreeSingleIndexAdaptorParams(10));
  d.tree->buildIndex();
  const bool gradients = options.color_gradients && d.cloud.hasColors();
  if (gradients) {
    d.intensity.resize(n);
    for (std::size_t i = 0; i < n; ++i) d.intensity[i] = colorIntensity(d.cloud.colors[i]);
    d.gradients.assign(n, Vector3f::Zero());
  }

  // PCA normals: eigenvector of the smallest eigenvalue of the k-neighbourhood covariance.
  const std::size_t k =
      std::min<std::size_t>(static_cast<std::size_t>(options.normal_neighbors), n);
  parallelChunks(n, 1024, options.threads, [&](std::size_t, std::size_t b, std::size_t e) {
    std::vector<std::size_t> idx(k);
    std::vector<float> d2(k);
    for (std::size_t i = b; i < e; ++i) {
      const std::size_t found =
          d.tree->knnSearch(d.cloud.points[i].data(), k, idx.data(), d2.data());
      if (found < 3) continue;
      Eigen::Vector3d mean = Eigen::Vector3d::Zero();
      for (std::size_t j = 0; j < found; ++j) mean += d.cloud.points[idx[j]].cast<double>();
      mean /= double(found);
      Eigen::Matrix3d cov = Eigen::Matrix3d::Zero();
      for (std::size_t j = 0; j < found; ++j) {
        const Eigen::Vector3d q = d.cloud.points[idx[j]].cast<double>() - mean;
        cov.noalias() += q * q.transpose();
      }
      cov /= double(found);
      Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> es(cov);  // ascending eigenvalues
      const Eigen::Vector3d ev = es.eigenvalues();
      if (!(ev(2) > 0.0)) continue;
      const double planarity = (ev(1) - ev(0)) / ev(2);
      Eigen::Vector3d normal = es.eigenvectors().col(0);
      // Orient towards the frame origin (the sensor) so normals are reproducible.
      if (normal.dot(d.cloud.points[i].cast<double>()) > 0.0) normal = -normal;
      normal.normalize();
      d.normals[i] = normal.cast<float>();
      d.valid[i] = planarity >= options.min_planarity ? 1 : 0;
      if (gradients && d.valid[i]) {
        // Intensity gradient on the tangent plane (Park, Zhou & Koltun 2017, eq. 10): least
        // squares over the neighbours projected on the plane, plus the constraint d·n = 0 as one
        // more row weighted like all the neighbours together.
        const Eigen::Vector3d p = d.cloud.points[i].cast<double>();
        const double Ip = d.intensity[i];
        Eigen::Matrix3d AtA = Eigen::Matrix3d::Zero();
        Eigen::Vector3d Atb = Eigen::Vector3d::Zero();
        for (std::size_t j = 0; j < found; ++j) {
          if (idx[j] == i) continue;
          const Eigen::Vector3d q = d.cloud.points[idx[j]].cast<double>();
          const Eigen::Vector3d a = (q - p) - normal * normal.dot(q - p);  // q' − p
          AtA.noalias() += a * a.transpose();
          Atb += a * (d.intensity[idx[j]] - Ip);
        }
        AtA.noalias() += double(found) * normal * normal.transpose();
        const Eigen::Vector3d g = AtA.ldlt().solve(Atb);
        if (g.allFinite()) d.gradients[i] = g.cast<float>();
      }
    }
  });
}

PreparedTarget::PreparedTarget(PointCloud target, SurfaceAttributes surface,
                               const Options& options)
    : impl_(std::make_unique<Impl>()) {
  const std::size_t n = target.size();
  OBM_ASSERT(options.voxel == 0.0, "PreparedTarget: a given surface needs voxel 0");
  OBM_ASSERT(surface.normals.size() == n && surface.valid.size() == n,
             "PreparedTarget: normals and their flags must be sized like the cloud");
  OBM_ASSERT(surface.gradients.empty() || (surface.gradients.size() == n && target.hasColors()),
             "PreparedTarget: colour gradients need a coloured cloud and one per point");
  auto& d = *impl_;
  d.options = options;
  d.cloud = std::move(target);
  for (const Vector3f& q : d.cloud.points)
    OBM_ASSERT(q.allFinite(), "PreparedTarget: a given surface needs finite points");
  d.normals = std::move(surface.normals);
  d.valid = std::move(surface.valid);
  d.adaptor.pts = &d.cloud.points;
  if (n == 0) return;
  d.tree = std::make_unique<KdTree>(3, d.adaptor, nanoflann::KDTreeSingleIndexAdaptorParams(10));
  d.tree->buildIndex();
  if (!surface.gradients.empty()) {
    d.gradients = std::move(surface.gradients);
    d.intensity.resize(n);
    for (std::size_t i = 0; i < n; ++i) d.intensity[i] = colorIntensity(d.cloud.colors[i]);
  }
}

PreparedTarget::~PreparedTarget() = default;
PreparedTarget::PreparedTarget(PreparedTarget&&) noexcept = default;
PreparedTarget& PreparedTarget::operator=(PreparedTarget&&) noexcept = default;

const PointCloud& PreparedTarget::cloud() const {
  return impl_->cloud;
}
std::size_t PreparedTarget::size() const {
  return impl_->cloud.size();
}
bool PreparedTarget::empty() const {
  return impl_->cloud.empty();
}
const std::vector<Vector3f>& PreparedTarget::normals() const {
  return impl_->normals;
}
const std::vector<std::uint8_t>& PreparedTarget::normalValid() const {
  return impl_->valid;
}
SurfaceAttributes PreparedTarget::surface() const {
  return {impl_->normals, impl_->valid, impl_->gradients};
}
bool PreparedTarget::hasColorGradients() const {
  return !impl_->gradients.empty();
}
const std::vector<float>& PreparedTarget::intensity() const {
  return impl_->intensity;
}
const std::vector<Vector3f>& PreparedTarget::colorGradients() const {
  return impl_->gradients;
}
double PreparedTarget::colorResidual(std::size_t j, const Eigen::Vector3d& x,
                                     float source_intensity) const {
  const auto& d = *impl_;
  const Eigen::Vector3d q = d.cloud.points[j].cast<double>();
  return d.intensity[j] + d.gradients[j].cast<double>().dot(x - q) - source_intensity;
}
const PreparedTarget::Options& PreparedTarget::options() const {
  return impl_->options;
}

bool PreparedTarget::nearest(const Vector3f& query, double max_distance, std::size_t& index,
                             float& distance2) const {
  if (!impl_->tree) return false;
  // Strictly inside the gate: nanoflann only adds points with d < worstDist.
  NearestWithin result(static_cast<float>(max_distance * max_distance));
  impl_->tree->findNeighbors(result, query.data(), nanoflann::SearchParams());
  if (!result.found()) return false;
  index = result.index();
  distance2 = result.worstDist();
  return true;
}

std::size_t PreparedTarget::knn(const Vector3f& query, std::size_t k,
                                std::vector<std::size_t>& indices,
                                std::vector<float>& distances2) const {
  indices.clear();
  distances2.clear();
  if (!impl_->tree || k == 0) return 0;
  k = std::min(k, impl_->cloud.size());
  indices.resize(k);
  distances2.resize(k);
  const std::size_t found =
      impl_->tree->knnSearch(query.data(), k, indices.data(), distances2.data());
  indices.resize(found);
  distances2.resize(found);
  return found;
}

}  // namespace obm::registration
