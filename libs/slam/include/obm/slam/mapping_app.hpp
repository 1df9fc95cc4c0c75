#pragma once
/// \file mapping_app.hpp
/// The logic of `obm-map` (docs/obm-map.md): plays a sequence — a KITTI odometry folder, an RGB-D
/// folder (TUM RGB-D, ICL-NUIM, 7-Scenes, Redwood) or an MRPT rawlog — through the SLAM front-end
/// (obm::frontend::Frontend), integrates the keyframes into an OctoMap (obm::mapping) and writes
/// to the output folder:
///
///   trajectory_tum.txt     every frame, T_world_sensor, TUM format (KITTI input: the LiDAR)
///   trajectory_kitti.txt   every frame, KITTI format; for a KITTI input the camera-0 poses
///                          T_cam = Tr·T_velo·Tr⁻¹ like the dataset's poses.txt (first = I)
///   keyframes_tum.txt      the keyframes' optimised poses, TUM format
///   frames.csv             per frame: status, keyframe, match quality, points
///   loops.csv              every verified loop candidate, accepted or not
///   graph.g2o              the pose graph (VERTEX_SE3:QUAT / EDGE_SE3:QUAT)
///   map.bt, map.ot         the OctoMap (maximum likelihood / full probabilities)
///   metrics.json           KITTI t_err / r_err, ATE, RPE against the ground truth, loop counts
///   timing.json            frames, wall time, frames/s, per-stage milliseconds
///   trajectory_topview.png the estimate (red) over the aligned ground truth (black), loops (blue)
///   map_topview.png        the map's top view (height of the highest occupied voxel)
///
/// Every file is written atomically. A cancel flag (Ctrl-C in the app) stops after the current
/// frame and everything processed so far is written.
#include <atomic>
#include <cstddef>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include "obm/core/se3.hpp"
#include "obm/frontend/frontend.hpp"
#include "obm/slam/slam_config.hpp"

namespace obm::slam {

/// Command-line level choices.
struct MappingAppOptions {
  std::string input;           ///< KITTI sequence folder, RGB-D folder or `.rawlog`
  std::string out_dir;         ///< output folder (created)
  std::string ground_truth;    ///< ground-truth file ("" = look next to the input)
  std::size_t max_frames = 0;  ///< stop after this many frames (0 = all)
  bool progress = true;        ///< progress bar on stderr
  /// Set (e.g. by a SIGINT handler) to stop after the current frame; outputs are still written.
  const std::atomic<bool>* cancel = nullptr;
};

/// Accuracy against the ground truth (NaN where not computable, e.g. no 100 m segment).
struct TrajectoryMetrics {
  std::size_t frames_evaluated = 0;  ///< frames with a ground-truth pose
  std::size_t kitti_segments = 0;
  double t_err_percent = 0.0;       ///< KITTI devkit translation error [%]
  double r_err_deg_per_100m = 0.0;  ///< KITTI devkit rotation error [deg/100 m]
  double ate_rmse_m = 0.0;          ///< after rigid (SE(3)) Umeyama alignment
  double ate_mean_m = 0.0;
  double ate_max_m = 0.0;
  double rpe_trans_rmse_m = 0.0;  ///< frame-to-frame relative pose error, translation [m]
  double rpe_rot_rmse_deg = 0.0;  ///< frame-to-frame relative pose error, rotation [deg]
  double length_m = 0.0;          ///< ground-truth path length [m]
  std::string frame;              ///< frame the poses were compared in ("camera0", "sensor")
  /// Accepted loop closures with ground truth at both ends, and those among them whose measured
  /// relative pose is off the ground truth's by more than kWrongLoopTranslation or
  /// kWrongLoopRotationDeg: loops the front-end should not have accepted. The largest errors of
  /// the accepted loops (NaN when none was checked).
  std::size_t loops_checked = 0;
  std::size_t loops_wrong = 0;
  double loop_error_max_m = 0.0;
  double loop_error_max_deg = 0.0;
};

/// A loop edge further than this from the ground truth's relative pose is counted wrong: the
/// scale of an ICP local minimum one facade element away, far above a correct registration's
/// centimetres.
inline constexpr double kWrongLoopTranslation = 0.5;  ///< [m]
inline constexpr double kWrongLoopRotationDeg = 2.0;  ///< [deg]

/// Scores the accepted loop closures against the ground truth: each measured T_from_to against
/// T_world_from⁻¹·T_world_to of the ground-truth poses of the two keyframes' frames (indexed by
/// frame, sensor frame at both ends). Sets m.loops_checked, loops_wrong and loop_error_max_*.
void scoreLoops(const std::vector<frontend::LoopClosure>& loops,
                const std::vector<std::size_t>& keyframe_frames,
                const std::vector<std::optional<Isometry3d>>& T_world_body, TrajectoryMetrics& m);

/// The scan matcher's results at one call site (loop verification or recovery), and how many
/// started from the network's own pose (registration::fromNetwork: the network's pose was
/// refined, not the caller's guess or a start the matcher made up).
struct MatcherSite {
  std::size_t results = 0;        ///< results the site judged (loops: every verified candidate)
  std::size_t network = 0;        ///< … whose refinement started from the network's pose
  std::size_t taken = 0;          ///< accepted loops / recovered frames
  std::size_t taken_network = 0;  ///< … from the network's pose
  std::size_t checked = 0;        ///< taken, with ground truth at both ends
  /// Checked and off the truth by more than kWrongLoopTranslation or kWrongLoopRotationDeg
  /// (loops: the loop's relative pose; recovery: the frame's motion from the frame before).
  std::size_t wrong = 0;
  std::size_t wrong_network = 0;  ///< … from the network's pose
};

/// Where the network's results were taken and whether they were right: what decides which call
/// sites should run it (metrics.json "matcher_ledger"; docs/obm-map.md).
struct MatcherLedger {
  MatcherSite loop_verification;
  MatcherSite recovery;
};

/// The ledger of a run. `starts` and `statuses` are per frame (the start of each frame's taken
/// match, its tracking status); `traj` the final trajectory; T_world_body the ground truth per
/// frame (empty or nullopt entries: not checked).
MatcherLedger matcherLedger(const std::vector<frontend::LoopClosure>& loops,
                            const std::vector<std::size_t>& keyframe_frames,
                            const std::vector<frontend::TrackingStatus>& statuses,
                            const std::vector<registration::MatchStart>& starts,
                            const std::vector<Isometry3d>& traj,
                            const std::vector<std::optional<Isometry3d>>& T_world_body);

/// What a run did.
struct RunSummary {
  std::string input_kind;  ///< "kitti", "tum-rgbd", "icl-nuim", "7scenes", "redwood", "rawlog"
  std::string matcher;     ///< loop / recovery matcher used ("icp", "obmnet+icp")
  std::size_t frames = 0;  ///< frames processed
  std::size_t frames_total = 0;  ///< frames in the input (0 = unknown, rawlog)
  frontend::FrontendStats stats;
  bool interrupted = false;  ///< the cancel flag stopped the run
  double wall_s = 0.0;       ///< whole run, outputs included
  double frames_per_second = 0.0;
  std::map<std::string, double> stages_ms;   ///< per-stage totals (timing.json)
  std::optional<TrajectoryMetrics> metrics;  ///< when ground truth was available
  MatcherLedger ledger;                      ///< the network's use per call site
  std::string ground_truth;                  ///< the ground-truth file used ("" = none)
  bool map_rebuilt = false;                  ///< the OctoMap was rebuilt at the final poses
  std::vector<std::string> files;            ///< files written
};

class MappingApp {
 public:
  /// Validates the options (ConfigError for an empty input / output). Inputs are opened by run().
  MappingApp(SlamConfig config, MappingAppOptions options);
  ~MappingApp();

  /// Plays the input and writes the outputs. Throws IoError / FormatError naming the file for a
  /// bad input, a missing or corrupt model, or an output folder that cannot be written — checked
  /// before the first frame; bad frames are counted and bridged, not thrown.
  RunSummary run();

  const SlamConfig& config() const { return config_; }

 private:
  SlamConfig config_;
  MappingAppOptions options_;
};

/// A one-screen text summary of a run (frames, keyframes, loops, metrics, speed, files).
std::string formatSummary(const RunSummary& summary);

/// Draws the top view of a trajectory (x right, y up, in the plane given by T_view_world's x–y):
/// `reference` (black, may be empty) under `estimate` (red), loop edges between estimate poses
/// (blue), start (green dot). Writes an RGB PNG atomically; returns the metres per pixel.
double writeTrajectoryPng(const std::string& path, const std::vector<Isometry3d>& estimate,
                          const std::vector<Isometry3d>& reference,
                          const std::vector<std::pair<std::size_t, std::size_t>>& loops,
                          const Isometry3d& T_view_world = Isometry3d::Identity(),
                          int max_pixels = 2048);

}  // namespace obm::slam
