#include "local_map.hpp"

#include <algorithm>

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

void LocalMap::rebuild(const std::vector<Keyframe>& keyframes, std::size_t frame_index,
                       bool allow_async, StageTimes& times) {
  if (pending_.valid()) {
    // Not installed yet (keyframes in quick succession): it is still a map of the current
    // world, better than the one in use.
    TimedStage s(times, Stage::LocalMapWait);
    BuiltMap m = pending_.get();
    current_ = std::move(m.target);
    addStageTime(times, Stage::LocalMapBuild, m.ms);
  }
  TimedStage s(times, Stage::LocalMap);
  const std::size_t k = keyframes.size() - 1;
  const std::size_t n = params_.keyframes;
  const std::size_t first = std::max(first_, k + 1 > n ? k + 1 - n : std::size_t{0});
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
  const bool async = allow_async && params_.async && current_ != nullptr;
  registration::PreparedTarget::Options opt = target_options_;
  if (async) opt.threads = 1;  // the other core tracks meanwhile
  const double voxel = k > first ? params_.voxel : 0.0;
  const Vector3f center = keyframes[k].T_world_sensor.translation().cast<float>();
  const float r2 = static_cast<float>(params_.radius * params_.radius);
  auto build = [cloud = std::move(merged), voxel, center, r2, opt]() mutable {
    Timer t;
    if (voxel > 0.0) cloud = voxelDownsample(cloud, voxel);
    PointCloud cropped;
    cropped.points.reserve(cloud.size());
    const bool colors = cloud.hasColors();
    for (std::size_t i = 0; i < cloud.size(); ++i)
      if ((cloud.points[i] - center).squaredNorm() <= r2) {
        cropped.points.push_back(cloud.points[i]);
        if (colors) cropped.colors.push_back(cloud.colors[i]);
      }
    cropped.frame_id = "world";
    BuiltMap m;
    m.target = std::make_unique<registration::PreparedTarget>(cropped, opt);
    m.ms = t.ms();
    return m;
  };
  if (async) {
    pending_ = std::async(std::launch::async, std::move(build));
    pending_from_frame_ = frame_index + kDelayFrames;
  } else {
    BuiltMap m = build();
    current_ = std::move(m.target);
  }
}

void LocalMap::installPending(std::size_t frame_index, StageTimes& times) {
  if (!pending_.valid() || frame_index < pending_from_frame_) return;
  BuiltMap m;
  {
    TimedStage s(times, Stage::LocalMapWait);
    m = pending_.get();
  }
  current_ = std::move(m.target);
  addStageTime(times, Stage::LocalMapBuild, m.ms);
}

}  // namespace obm::frontend
