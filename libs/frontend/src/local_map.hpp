#pragma once
/// \file local_map.hpp
/// The local map every frame is registered against: the clouds of the newest keyframes (since
/// the last restart) at their current pose estimates, merged on a voxel grid in the world frame,
/// cropped to a radius around the newest keyframe and prepared (KD-tree, normals) for the
/// tracking ICP. Rebuilt after keyframes, asynchronously when LocalMapParams::async: the build
/// runs in a worker thread and the result is installed a fixed number of frames later, so results
/// do not depend on timing. Private to libs/frontend.
#include <cstddef>
#include <future>
#include <map>
#include <memory>
#include <utility>
#include <vector>

#include "obm/core/timer.hpp"
#include "obm/frontend/frontend.hpp"
#include "obm/frontend/params.hpp"
#include "obm/registration/prepared_target.hpp"

namespace obm::frontend {

/// The clouds of keyframes[i] for each i of `indices` (in that order), moved into the frame F of
/// T_frame_world, merged and put on a voxel grid of edge `voxel` (0: none). Points only: the
/// submaps of loop verification and of the gap paths' earlier maps.
PointCloud mergeKeyframeClouds(const std::vector<Keyframe>& keyframes,
                               const std::vector<std::size_t>& indices,
                               const Isometry3d& T_frame_world, double voxel);

class LocalMap {
 public:
  /// An asynchronously rebuilt map replaces the current one this many frames after the keyframe
  /// that triggered it (time for the worker; fixed, so results do not depend on timing).
  static constexpr std::size_t kDelayFrames = 3;

  /// `target_options`: how the merged cloud is prepared (the tracking ICP's target options).
  LocalMap(const LocalMapParams& params,
           const registration::PreparedTarget::Options& target_options);
  /// Waits for a build still running.
  ~LocalMap();
  LocalMap(const LocalMap&) = delete;
  LocalMap& operator=(const LocalMap&) = delete;

  bool exists() const { return current_ != nullptr; }
  /// The map in use (exists() must be true).
  const registration::PreparedTarget& target() const { return *current_; }

  /// Tracks against `target` (world frame) until the next rebuild: the earlier map a gap
  /// recovery registered the frame against. A build still pending is finished first (the keyframe
  /// surfaces it estimated are kept), then replaced.
  void adopt(std::unique_ptr<registration::PreparedTarget> target);

  /// From now on the map holds keyframes from `first_keyframe` on only (a restart).
  void restartAt(std::size_t first_keyframe) { first_ = first_keyframe; }

  /// After `keyframes.back()` was added: rebuilds at once when it restarts the map (`bridged`)
  /// or there is no map yet, else asynchronously at every LocalMapParams::rebuild_every-th
  /// keyframe since the restart. `frame_index` is the current frame's.
  void afterKeyframe(const std::vector<Keyframe>& keyframes, std::size_t frame_index,
                     bool bridged, StageTimes& times);

  /// Rebuilds from the newest keyframes at their current poses (stage "local_map"). A build
  /// still pending is installed first (stage "local_map_wait"). Asynchronous when
  /// `allow_async`, LocalMapParams::async and a map exists: the merged points go to a worker
  /// thread (one thread for the KD-tree and normals; the other core tracks meanwhile) and the
  /// result replaces the map at frame `frame_index + kDelayFrames`.
  void rebuild(const std::vector<Keyframe>& keyframes, std::size_t frame_index, bool allow_async,
               StageTimes& times);

  /// Keyframe surfaces estimated so far (LocalMapParams::keyframe_normals: once per keyframe).
  std::size_t surfacesEstimated() const { return surfaces_estimated_; }

  /// Installs the asynchronously built map when its frame has come (waits for it if needed,
  /// stage "local_map_wait"; the worker's build time goes to "local_map_build").
  void installPending(std::size_t frame_index, StageTimes& times);

  /// A keyframe's points (sensor frame, finite) and their surface, estimated once when
  /// LocalMapParams::keyframe_normals.
  struct KeyframeSurface {
    PointCloud cloud;
    registration::SurfaceAttributes surface;
  };

 private:
  using SurfacePtr = std::shared_ptr<const KeyframeSurface>;
  struct BuiltMap {
    std::unique_ptr<registration::PreparedTarget> target;
    double ms = 0.0;  // build time in the worker
    std::vector<std::pair<std::size_t, SurfacePtr>> new_surfaces;  // keyframe index -> surface
  };
  void install(BuiltMap&& m);  // the map, and the surfaces it estimated

  LocalMapParams params_;
  registration::PreparedTarget::Options target_options_;
  std::unique_ptr<registration::PreparedTarget> current_;
  std::future<BuiltMap> pending_;       // the next local map, being built
  std::size_t pending_from_frame_ = 0;  // frame index from which it replaces the current one
  std::size_t first_ = 0;               // oldest keyframe the map may use (after a restart)
  std::map<std::size_t, SurfacePtr> surfaces_;  // keyframe index -> its surface (keyframe_normals)
  std::size_t surfaces_estimated_ = 0;
};

}  // namespace obm::frontend
