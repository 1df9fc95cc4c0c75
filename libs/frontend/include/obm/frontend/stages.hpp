#pragma once
/// \file stages.hpp
/// The timing stages of a mapping run (Frontend::times(), timing.json), as values: a misspelt
/// stage is a compile error, not a new row in timing.json.
#include "obm/core/timer.hpp"

namespace obm::frontend {

enum class Stage {
  // The front-end (Frontend::times()).
  Preprocess,     ///< "preprocess": cleaning, cropping, voxel grid of the sweep
  Icp,            ///< "icp": tracking against the local map and the wide_gate recovery step
  StartSearch,    ///< "start_search": the scan matcher's start for the second frame
  LocalMap,       ///< "local_map": handing keyframes to the local map
  LocalMapBuild,  ///< "local_map_build": building it (asynchronous; its own thread's time)
  LocalMapWait,   ///< "local_map_wait": waiting for a build still running
  LoopSearch,     ///< "loop_search": candidates and their descriptor check
  Obmnet,         ///< "obmnet": a global scan matcher's work (loop verification, last_keyframe)
  LoopIcp,        ///< "loop_icp": a local scan matcher's work (the same, with ICP or OBMM + ICP)
  Relocalise,     ///< "relocalise": the search for a lost piece over the whole map
  Graph,          ///< "graph": pose-graph edges and optimisation
  // The mapping app (libs/slam).
  Read,           ///< "read": waiting for the next frame from the reader thread
  OctomapQueue,   ///< "octomap_queue": handing a keyframe to the OctoMap worker
  Octomap,        ///< "octomap": the worker's insertion time
  Autosave,       ///< "autosave": periodic outputs of a long run
  Output,         ///< "output": the outputs at the end
};

/// The stage's name in timing.json ("preprocess", "icp", ...).
const char* toString(Stage stage);

/// Times its scope into `times` under the stage's name.
class TimedStage : public ScopedStage {
 public:
  TimedStage(StageTimes& times, Stage stage) : ScopedStage(times, toString(stage)) {}
};

/// Adds `ms` to the stage (time measured elsewhere, e.g. in a worker thread).
inline void addStageTime(StageTimes& times, Stage stage, double ms) {
  times.add(toString(stage), ms);
}

}  // namespace obm::frontend
