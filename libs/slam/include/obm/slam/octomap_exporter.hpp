#pragma once
/// \file octomap_exporter.hpp
/// The logic of the `obm-octomap` tool: builds an OctoMap `.bt` / `.ot` (and optionally a top-view
/// PNG) from a sensor sequence and a trajectory (docs/obm-octomap.md).
///
/// Inputs (detected from `input`):
///  - a KITTI odometry folder (`velodyne/*.bin`, `calib.txt`, `times.txt`); a KITTI-format
///    trajectory holds T_world_cam0 per scan like the dataset's `poses.txt` and is turned into
///    LiDAR poses with `Tr` (T_world_velo = Tr⁻¹ · T_world_cam0 · Tr); a TUM trajectory holds
///    LiDAR poses T_world_velo and is associated with `times.txt` by time stamp;
///  - an RGB-D folder (TUM RGB-D `depth.txt`, ICL-NUIM `associations.txt`, 7-Scenes
///    `frame-*.depth.png`, Redwood `depth/`); trajectories hold T_world_camera (optical frame);
///  - an MRPT rawlog (`*.rawlog`); its clouds are in the vehicle frame, so trajectories hold
///    T_world_vehicle.
/// `trajectory` may also be an `obm-map` output folder: its `trajectory_kitti.txt` is used for a
/// KITTI input, `trajectory_tum.txt` otherwise (or whichever exists).
///
/// Everything is checked before the first scan is inserted (folder layout, trajectory lines, pose
/// count); on bad input nothing is written. Outputs are written atomically at the end, also when
/// `cancel` stops the integration early (the map then holds the scans integrated so far).
#include <atomic>
#include <cstddef>
#include <string>

#include "obm/mapping/mapping_params.hpp"
#include "obm/mapping/occupancy_map.hpp"

namespace obm::slam {

using mapping::MappingParams;
using mapping::OccupancyMap;
using mapping::TopViewInfo;
using mapping::TopViewOptions;
using mapping::MapStats;

/// Layout of a trajectory file.
enum class TrajectoryFormat {
  Auto,   ///< from the number of columns of the first pose line: 12 → KITTI, 8 → TUM
  Kitti,  ///< 12 numbers per line (row-major 3×4 [R|t]), one pose per frame
  Tum,    ///< `t tx ty tz qx qy qz qw`, associated with the frames by time stamp
};

/// Parses "auto", "kitti" or "tum"; throws ConfigError otherwise.
TrajectoryFormat parseTrajectoryFormat(const std::string& s);

/// The format of a trajectory file from its first pose line (comments `#` and blank lines
/// skipped). Throws IoError when the file cannot be read and FormatError(file, line) when the line
/// has neither 12 nor 8 numbers, or there is no pose line.
TrajectoryFormat detectTrajectoryFormat(const std::string& path);

/// Options of the exporter (the tool's command line).
struct ExporterOptions {
  std::string input;       ///< sequence folder or rawlog file
  std::string trajectory;  ///< trajectory file, or an obm-map output folder
  TrajectoryFormat format = TrajectoryFormat::Auto;
  std::string output;  ///< map file: `*.bt` (binary, maximum likelihood) or `*.ot` (full)
  std::string png;     ///< optional top-view picture (`*.png`); "" = none
  /// Use a ColorOcTree when the input carries colour (RGB-D with PNG colour images, coloured
  /// rawlog clouds); otherwise ignored with a warning.
  bool color = false;
  std::size_t every = 1;  ///< integrate every N-th frame (1 = all)
  /// [s] strict bound on |t_frame − t_pose| for TUM trajectories (TUM associate.py's default).
  double max_time_difference = 0.02;
  /// [s] added to the TUM trajectory's time stamps before association (e.g. −UNIX start time
  /// when the poses carry UNIX time and the frames sequence time).
  double time_offset = 0.0;
  /// [m] RGB-D inputs: depth beyond this is dropped before insertion (0 = keep all; beams longer
  /// than mapping.max_range then clear free space up to it without marking an end point).
  double rgbd_max_depth = 0.0;
  MappingParams mapping;  ///< resolution, max range, pre-filter, probabilities
  TopViewOptions top_view;
  bool progress = true;  ///< progress bar on stderr
  /// Set (e.g. by a SIGINT handler) to stop after the current scan; the map so far is written.
  const std::atomic<bool>* cancel = nullptr;
};

/// What a run did.
struct ExportSummary {
  std::string input_kind;       ///< "kitti", "tum-rgbd", "icl-nuim", "7scenes", "redwood", "rawlog"
  std::string trajectory_path;  ///< the trajectory file used
  TrajectoryFormat trajectory_format = TrajectoryFormat::Auto;  ///< the format read
  std::size_t frames = 0;                                       ///< frames in the input
  std::size_t frames_with_pose = 0;                             ///< frames that have a pose
  std::size_t frames_selected = 0;  ///< with a pose and picked by `every`
  std::size_t frames_integrated = 0;
  std::size_t read_errors = 0;  ///< selected frames that could not be read (skipped, each named in a warning)
  std::size_t points = 0;    ///< points of the integrated frames
  std::size_t rays = 0;      ///< points handed to the ray caster (after the pre-filter)
  std::size_t beams = 0;     ///< beams cast (one per distinct end cell with discretize)
  bool color = false;        ///< a ColorOcTree was built
  bool interrupted = false;  ///< `cancel` stopped the integration early
  MapStats stats;            ///< of the written map
  std::string output;        ///< map file written
  std::string png;           ///< picture written ("" = none)
  TopViewInfo top_view;      ///< geometry of the picture
  double integrate_s = 0.0;  ///< [s] reading + insertion
  double total_s = 0.0;      ///< [s] whole run
};

/// Builds the map of a sequence at the poses of a trajectory.
class OctomapExporter {
 public:
  /// Checks the options (ConfigError for a bad value or extension); inputs are opened by run().
  explicit OctomapExporter(ExporterOptions options);

  /// Opens and checks the inputs, integrates the selected frames, writes the outputs. Throws
  /// IoError / FormatError naming the file (and line) for bad input, before anything is written.
  ExportSummary run();

  const ExporterOptions& options() const noexcept { return opt_; }

 private:
  ExporterOptions opt_;
};

/// The end-of-run report: frames, map size (nodes, leaves), occupied and free volume, memory,
/// bounding box, time.
std::string formatSummary(const ExportSummary& summary);

}  // namespace obm::slam
