#include "local_map.hpp"

#include <algorithm>
#include <functional>

#include "obm/frontend/stages.hpp"
#include "obm/core/cloud_ops.hpp"

namespace obm::frontend {

LocalMap::LocalMap(const LocalMapParams& params,
                   const registration::PreparedTarget::Options& target_options)
    : params_(params), target_options_(target_options) {}

LocalMap::~LocalMap() = default;

void LocalMap::afterKeyframe(const std::vector<Keyframe>& keyframes, std::size_t frame_index,
                             bool bridged, StageTimes& times) {
  // A restart needs the new map at once; otherwise every rebuild_every-th keyframe.
  const std::size_t since_restart = keyframes.size() - 1 - first_;
  if (bridged || current_ == nullptr || since_restart % params_.rebuild_every == 0)
    rebuild(keyframes, frame_index, !bridged, times);
}

namespace {

/// Cropped to the ball of radius² `r2` around `center`: the indices kept.
std::vector<std::size_t> insideBall(const std::vector<Vector3f>& points, const Vector3f& center,
                                    float r2) {
  std::vector<std::size_t> keep;
  keep.reserve(points.size());
  for (std::size_t i = 0; i < points.size(); ++i)
    if ((points[i] - center).squaredNorm() <= r2) keep.push_back(i);
  return keep;
}

/// The merged cloud of surfaces already in the world frame, on a voxel grid of edge `voxel` (0:
/// no grid): per voxel the centroid, the mean colour, and the mean of the *trusted* normals and
/// colour gradients. A voxel's normal is trusted when one of its points' is and the trusted ones
/// agree (their mean is at least 0.8 long: the views see one plane, not a corner).
void mergeOnGrid(PointCloud& cloud, registration::SurfaceAttributes& s, double voxel) {
  if (voxel <= 0.0) return;
  std::vector<std::uint32_t> ids;
  const std::size_t m = voxelIds(cloud.points, voxel, ids);
  const bool colors = cloud.hasColors(), gradients = !s.gradients.empty();
  std::vector<Eigen::Vector3d> sum(m, Eigen::Vector3d::Zero()), csum, nsum(m, Eigen::Vector3d::Zero()),
      nall(m, Eigen::Vector3d::Zero()), gsum;
  std::vector<std::uint32_t> count(m, 0), trusted(m, 0);
  if (colors) csum.assign(m, Eigen::Vector3d::Zero());
  if (gradients) gsum.assign(m, Eigen::Vector3d::Zero());
  for (std::size_t i = 0; i < cloud.size(); ++i) {
    const std::uint32_t v = ids[i];
    sum[v] += cloud.points[i].cast<double>();
    ++count[v];
    if (colors) csum[v] += cloud.colors[i].cast<double>();
    nall[v] += s.normals[i].cast<double>();
    if (s.valid[i]) {
      nsum[v] += s.normals[i].cast<double>();
      ++trusted[v];
      if (gradients) gsum[v] += s.gradients[i].cast<double>();
    }
  }
  PointCloud out;
  out.frame_id = cloud.frame_id;
  out.timestamp = cloud.timestamp;
  out.points.resize(m);
  if (colors) out.colors.resize(m);
  registration::SurfaceAttributes o;
  o.normals.resize(m);
  o.valid.assign(m, 0);
  if (gradients) o.gradients.assign(m, Vector3f::Zero());
  for (std::size_t v = 0; v < m; ++v) {
    out.points[v] = (sum[v] / double(count[v])).cast<float>();
    if (colors)
      out.colors[v] = (csum[v] / double(count[v])).array().round().cast<std::uint8_t>().matrix();
    const Eigen::Vector3d& n = trusted[v] > 0 ? nsum[v] : nall[v];
    const double len = n.norm();
    o.normals[v] = len > 0.0 ? Vector3f((n / len).cast<float>()) : Vector3f::Zero();
    if (trusted[v] > 0 && len >= 0.8 * double(trusted[v])) {
      o.valid[v] = 1;
      if (gradients) o.gradients[v] = (gsum[v] / double(trusted[v])).cast<float>();
    }
  }
  cloud = std::move(out);
  s = std::move(o);
}

}  // namespace

PointCloud mergeKeyframeClouds(const std::vector<Keyframe>& keyframes,
                               const std::vector<std::size_t>& indices,
                               const Isometry3d& T_frame_world, double voxel) {
  PointCloud merged;
  std::size_t total = 0;
  for (std::size_t i : indices) total += keyframes[i].cloud.size();
  merged.points.reserve(total);
  for (std::size_t i : indices) {
    const Eigen::Isometry3f T = (T_frame_world * keyframes[i].T_world_sensor).cast<float>();
    for (const Vector3f& q : keyframes[i].cloud.points) merged.points.push_back(T * q);
  }
  return voxel > 0.0 ? voxelDownsample(merged, voxel) : merged;
}

void LocalMap::adopt(std::unique_ptr<registration::PreparedTarget> target) {
  if (pending_.valid()) install(pending_.get());  // keeps the surfaces it estimated
  current_ = std::move(target);
}

void LocalMap::install(BuiltMap&& m) {
  current_ = std::move(m.target);
  surfaces_estimated_ += m.new_surfaces.size();
  for (auto& [index, surface] : m.new_surfaces) surfaces_[index] = std::move(surface);
}

void LocalMap::rebuild(const std::vector<Keyframe>& keyframes, std::size_t frame_index,
                       bool allow_async, StageTimes& times) {
  if (pending_.valid()) {
    // Not installed yet (keyframes in quick succession): it is still a map of the current
    // world, better than the one in use.
    TimedStage s(times, Stage::LocalMapWait);
    BuiltMap m = pending_.get();
    addStageTime(times, Stage::LocalMapBuild, m.ms);
    install(std::move(m));
  }
  TimedStage s(times, Stage::LocalMap);
  const std::size_t k = keyframes.size() - 1;
  const std::size_t n = params_.keyframes;
  const std::size_t first = std::max(first_, k + 1 > n ? k + 1 - n : std::size_t{0});
  const bool async = allow_async && params_.async && current_ != nullptr;
  registration::PreparedTarget::Options opt = target_options_;
  if (async) opt.threads = 1;  // the other core tracks meanwhile
  const double voxel = k > first ? params_.voxel : 0.0;
  const Vector3f center = keyframes[k].T_world_sensor.translation().cast<float>();
  const float r2 = static_cast<float>(params_.radius * params_.radius);

  std::function<BuiltMap()> build;
  if (params_.keyframe_normals) {
    // Each keyframe's surface is estimated once, on its own cloud (the k-NN search is the build's
    // largest cost), and the local map merges the surfaces; the worker estimates the new ones.
    surfaces_.erase(surfaces_.begin(), surfaces_.lower_bound(first));
    struct Piece {
      std::size_t index;
      Eigen::Isometry3f T_world_sensor;
      SurfacePtr surface;  // known, or null: estimate it from `cloud`
      PointCloud cloud;
    };
    std::vector<Piece> pieces;
    for (std::size_t i = first; i <= k; ++i) {
      if (keyframes[i].cloud.empty()) continue;
      Piece piece{i, keyframes[i].T_world_sensor.cast<float>(), nullptr, {}};
      const auto it = surfaces_.find(i);
      if (it != surfaces_.end() && it->second->cloud.size() <= keyframes[i].cloud.size())
        piece.surface = it->second;
      else
        piece.cloud = keyframes[i].cloud;
      pieces.push_back(std::move(piece));
    }
    const double grid = std::max(voxel, opt.voxel);
    build = [pieces = std::move(pieces), grid, center, r2, opt]() mutable {
      Timer t;
      BuiltMap m;
      registration::PreparedTarget::Options own = opt;
      own.voxel = 0.0;
      std::size_t total = 0;
      for (Piece& p : pieces) {
        if (!p.surface) {
          registration::PreparedTarget prepared(p.cloud, own);
          auto kf = std::make_shared<KeyframeSurface>();
          kf->cloud = prepared.cloud();
          kf->surface = prepared.surface();
          p.surface = kf;
          m.new_surfaces.emplace_back(p.index, p.surface);
        }
        total += p.surface->cloud.size();
      }
      bool colors = true, gradients = true;
      for (const Piece& p : pieces) {
        colors = colors && p.surface->cloud.hasColors();
        gradients = gradients && !p.surface->surface.gradients.empty();
      }
      PointCloud merged;
      merged.frame_id = "world";
      registration::SurfaceAttributes surface;
      merged.points.reserve(total);
      surface.normals.reserve(total);
      surface.valid.reserve(total);
      if (colors) merged.colors.reserve(total);
      if (gradients) surface.gradients.reserve(total);
      for (const Piece& p : pieces) {
        const Eigen::Isometry3f& T = p.T_world_sensor;
        const PointCloud& c = p.surface->cloud;
        const registration::SurfaceAttributes& a = p.surface->surface;
        for (std::size_t i = 0; i < c.size(); ++i) {
          merged.points.push_back(T * c.points[i]);
          surface.normals.push_back(T.linear() * a.normals[i]);
          if (gradients) surface.gradients.push_back(T.linear() * a.gradients[i]);
        }
        surface.valid.insert(surface.valid.end(), a.valid.begin(), a.valid.end());
        if (colors) merged.colors.insert(merged.colors.end(), c.colors.begin(), c.colors.end());
      }
      if (!gradients) surface.gradients.clear();
      mergeOnGrid(merged, surface, grid);
      const std::vector<std::size_t> keep = insideBall(merged.points, center, r2);
      registration::SurfaceAttributes kept;
      kept.normals.reserve(keep.size());
      kept.valid.reserve(keep.size());
      for (std::size_t i : keep) {
        kept.normals.push_back(surface.normals[i]);
        kept.valid.push_back(surface.valid[i]);
        if (!surface.gradients.empty()) kept.gradients.push_back(surface.gradients[i]);
      }
      PointCloud cropped = merged.select(keep);
      cropped.frame_id = "world";
      m.target = std::make_unique<registration::PreparedTarget>(std::move(cropped),
                                                                std::move(kept), own);
      m.ms = t.ms();
      return m;
    };
  } else {
    PointCloud merged;
    std::size_t total = 0;
    // Colours are merged for coloured ICP's photometric term, when every keyframe has them.
    bool colors = target_options_.color_gradients;
    for (std::size_t i = first; i <= k; ++i) {
      total += keyframes[i].cloud.size();
      colors = colors && keyframes[i].cloud.hasColors();
    }
    merged.points.reserve(total);
    if (colors) merged.colors.reserve(total);
    for (std::size_t i = first; i <= k; ++i) {
      const Eigen::Isometry3f T = keyframes[i].T_world_sensor.cast<float>();
      for (const Vector3f& q : keyframes[i].cloud.points) merged.points.push_back(T * q);
      if (colors)
        merged.colors.insert(merged.colors.end(), keyframes[i].cloud.colors.begin(),
                             keyframes[i].cloud.colors.end());
    }
    build = [cloud = std::move(merged), voxel, center, r2, opt]() mutable {
      Timer t;
      if (voxel > 0.0) cloud = voxelDownsample(cloud, voxel);
      PointCloud cropped = cloud.select(insideBall(cloud.points, center, r2));
      cropped.frame_id = "world";
      BuiltMap m;
      m.target = std::make_unique<registration::PreparedTarget>(cropped, opt);
      m.ms = t.ms();
      return m;
    };
  }
  if (async) {
    pending_ = std::async(std::launch::async, std::move(build));
    pending_from_frame_ = frame_index + kDelayFrames;
  } else {
    install(build());  // timed as "local_map" by this scope
  }
}

void LocalMap::installPending(std::size_t frame_index, StageTimes& times) {
  if (!pending_.valid() || frame_index < pending_from_frame_) return;
  BuiltMap m;
  {
    TimedStage s(times, Stage::LocalMapWait);
    m = pending_.get();
  }
  addStageTime(times, Stage::LocalMapBuild, m.ms);
  install(std::move(m));
}

}  // namespace obm::frontend
