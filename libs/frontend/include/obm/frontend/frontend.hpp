#pragma once
/// \file frontend.hpp
/// The SLAM front-end (docs/obm-map.md): every sweep is preprocessed and registered against a
/// local map of recent keyframes starting from a constant-velocity guess; keyframes become nodes
/// of a pose graph (obm::backend) joined by odometry edges; loop closures are searched near each
/// keyframe, verified by the scan matcher (OBMNet + ICP or ICP) and added as robust edges, after
/// which the graph is optimised and the local map rebuilt at the corrected poses.
///
/// Failures are expected and handled, not thrown: an empty, non-finite or corrupted sweep, or a
/// match that is poor or jumps far from the guess, is first retried with a wide-gate recovery ICP
/// and otherwise bridged with the constant-velocity guess (a warning is logged, throttled); a
/// bridged frame is never a keyframe, and after `tracking.max_bridge_frames` bridged frames in a
/// row the local map restarts at the current frame with a weak bridge edge.
///
/// Every frame gets a pose: T_world_frame = T_world_keyframe · T_keyframe_frame with the keyframe
/// the frame was tracked from, so pose-graph corrections carry over to the frames in between.
/// The world frame is the sensor frame of the first frame.
#include <cstddef>
#include <memory>
#include <string>
#include <vector>

#include "obm/backend/pose_graph.hpp"
#include "obm/core/point_cloud.hpp"
#include "obm/core/se3.hpp"
#include "obm/core/timer.hpp"
#include "obm/frontend/descriptor.hpp"
#include "obm/frontend/params.hpp"
#include "obm/frontend/preprocess.hpp"
#include "obm/frontend/rejection.hpp"
#include "obm/registration/match_result.hpp"
#include "obm/registration/scan_matcher.hpp"

namespace obm::frontend {

/// How a frame's pose was obtained.
enum class TrackingStatus {
  Initial,    ///< the first frame (identity), or a frame before any usable sweep
  Tracked,    ///< registered against the local map, accepted
  Recovered,  ///< the match was rejected, the wide-gate recovery succeeded
  Bridged,    ///< no usable match: the constant-velocity guess
};

/// "initial", "tracked", "recovered", "bridged".
const char* toString(TrackingStatus status);

/// What process() did with one frame.
struct FrameResult {
  std::size_t index = 0;   ///< 0-based frame number (order of process() calls)
  double timestamp = 0.0;  ///< [s] the sweep's time stamp
  TrackingStatus status = TrackingStatus::Initial;
  /// The test the tracking match failed (None when tracked): why the frame was recovered or
  /// bridged, or NoSweep.
  RejectionKind rejection = RejectionKind::None;
  std::string reason;           ///< the same in words, with each recovery step's finding ("" when tracked)
  bool keyframe = false;        ///< the frame became a keyframe
  bool restarted = false;       ///< the local map restarted at this frame (after a bridge run)
  std::size_t keyframe_id = 0;  ///< keyframe the pose is attached to
  Isometry3d T_world_sensor = Isometry3d::Identity();  ///< estimate right after processing
  registration::MatchResult match;  ///< the accepted (or last tried) tracking match
  std::size_t loops_accepted = 0;  ///< loop closures accepted at this frame
  PreprocessStats preprocess;      ///< points kept / dropped
};

/// A keyframe: a pose-graph node with its cloud.
struct Keyframe {
  std::size_t id = 0;                                  ///< node id in the pose graph (0, 1, 2, ...)
  std::size_t frame_index = 0;                         ///< the frame it was made from
  double timestamp = 0.0;                              ///< [s]
  Isometry3d T_world_sensor = Isometry3d::Identity();  ///< current (optimised) estimate
  PointCloud cloud;            ///< sensor frame, cropped and voxelised at local_map.voxel
  PlaceDescriptor descriptor;  ///< empty when the descriptor is disabled
  double travelled = 0.0;      ///< [m] path length of the estimate up to this keyframe
  bool bridged = false;        ///< joined to the previous keyframe by a bridge edge (restart)
  /// The cloud and descriptor were dropped: an older keyframe stores the place
  /// (KeyframeParams::revisit_radius). Not a loop candidate.
  bool dropped = false;
};

/// One verified loop-closure candidate.
struct LoopClosure {
  std::size_t from = 0;                           ///< older keyframe (the target)
  std::size_t to = 0;                             ///< newer keyframe (the source)
  Isometry3d T_from_to = Isometry3d::Identity();  ///< the verified relative pose
  double quality = 0.0;
  double inlier_ratio = 0.0;
  double descriptor_distance = -1.0;  ///< -1 when not computed
  double correction = 0.0;  ///< [m] distance between the verified pose and the current estimate
  double correction_rotation = 0.0;  ///< [rad] rotation between the verified pose and the estimate
  bool accepted = false;
  /// Where the matcher's refinement started: the guess from the graph, or the network's pose.
  registration::MatchStart start = registration::MatchStart::Guess;
  /// Found by relocalisation (place recognition over the whole map after the drive was lost), not
  /// by the proximity search around the estimate.
  bool relocalisation = false;
  RejectionKind rejection = RejectionKind::None;  ///< the test it failed (None when accepted)
  std::string reason;  ///< the same in words ("" when accepted)
};

/// Counters of a run.
struct FrontendStats {
  std::size_t frames = 0;
  std::size_t keyframes = 0;
  std::size_t tracked = 0;
  std::size_t recovered = 0;
  std::size_t bridged = 0;
  std::size_t restarts = 0;      ///< local-map restarts after a run of bridged frames
  std::size_t empty_sweeps = 0;  ///< sweeps with no usable point (empty, all NaN, out of range)
  std::size_t loop_searches = 0;
  std::size_t loop_candidates = 0;  ///< candidates verified by the matcher
  std::size_t loops_accepted = 0;
  std::size_t loops_rejected = 0;
  std::size_t optimizations = 0;
  std::size_t keyframes_dropped = 0;  ///< keyframes whose cloud was dropped on a revisit
  /// Pieces of the drive after a local-map restart moved onto the map by relocalisation.
  std::size_t relocalisations = 0;
};

/// Which matcher the front-end uses for loop verification and recovery.
struct MatcherChoice {
  registration::ScanMatcherConfig config;  ///< what will be built
  bool fell_back = false;    ///< the configured OBMNet model was missing and the fallback is used
  std::string message;       ///< one line for the log ("matcher: icp (model ... not found)")
};

/// Applies the documented fallback: when `params.matcher.type` needs a model file that does not
/// exist and `params.matcher_fallback` is set, the fallback type is used (same icp / confidence
/// settings). Throws IoError naming the model file when it is missing and there is no fallback.
MatcherChoice chooseMatcher(const FrontendParams& params);

class Frontend {
 public:
  /// Builds the matchers (chooseMatcher; a corrupt model throws FormatError naming the file).
  explicit Frontend(const FrontendParams& params);
  /// With a given loop / recovery matcher (tests, tools).
  Frontend(const FrontendParams& params, std::unique_ptr<registration::ScanMatcher> matcher);
  ~Frontend();
  Frontend(const Frontend&) = delete;
  Frontend& operator=(const Frontend&) = delete;

  /// Processes the next sweep (points in the sensor frame, `timestamp` set). Frames must come in
  /// time order. Never throws for bad sweeps (they are bridged and counted).
  FrameResult process(const PointCloud& sweep);

  /// Final pose-graph optimisation (when loop edges were added since the last one). Safe to call
  /// more than once; process() may not be called afterwards.
  void finish();

  /// Current estimate of every processed frame, T_world_sensor.
  std::vector<Isometry3d> trajectory() const;
  std::vector<double> timestamps() const;
  std::vector<TrackingStatus> statuses() const;
  /// Keyframe id each frame is attached to.
  std::vector<std::size_t> frameKeyframes() const;
  const std::vector<Keyframe>& keyframes() const;
  const std::vector<LoopClosure>& loops() const;
  /// The pose graph at the current estimate (nodes = keyframes, first one fixed).
  backend::PoseGraph graph() const;
  const FrontendStats& stats() const;
  /// Per-stage wall time: preprocess, local_map, icp (tracking), loop_search, obmnet / loop_icp
  /// (verification by an OBMNet or an ICP-only matcher), graph.
  const StageTimes& times() const;
  /// The loop / recovery matcher's name ("icp", "obmnet+icp", ...).
  std::string matcherName() const;
  const FrontendParams& params() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace obm::frontend
