#pragma once
/// \file simulator.hpp
/// The sequence simulator behind `obm-sim`: a YAML configuration (scene, sensor, trajectory,
/// output) → a dataset folder in the KITTI odometry or TUM RGB-D layout plus an MRPT rawlog,
/// ground truth and pictures. The folder is written under a temporary name and renamed at the
/// end, so a failure or an interrupt leaves nothing partial behind.
///
/// Output, LiDAR (`output.format: kitti`):
///   velodyne/NNNNNN.bin   float32 x y z intensity per point, LiDAR frame (x fwd, y left, z up)
///   poses.txt             KITTI 3×4 per sweep: T_cam0_0_cam0_i (camera-0 frame, via calib Tr)
///   times.txt             [s] per sweep, from 0
///   calib.txt             P0 and Tr (velodyne → camera 0), KITTI sequence 00's values
///   groundtruth.txt       TUM: t, T_lidar0_lidar_i (LiDAR frame, first pose = identity), t as in
///                         the rawlog (times.txt = t − t₀)
///   sequence.rawlog       MRPT CObservationPointCloud per sweep (sensorPose = identity: the
///                         vehicle frame is the LiDAR frame)
/// Output, RGB-D (`output.format: tum`):
///   depth/<t>.png         16-bit depth, 5000 units per metre (TUM); 0 = no measurement
///   rgb/<t>.png           shaded colour (when sensor.color)
///   depth.txt, rgb.txt    TUM file lists
///   groundtruth.txt       TUM: t, T_world_camera (optical frame) in the trajectory's world
///                         frame (the motion-capture frame for the TUM presets)
///   poses.txt, times.txt  the same poses in KITTI layout relative to the first frame
///   camera_intrinsic.json Open3D pinhole intrinsics
///   sequence.rawlog       MRPT CObservation3DRangeScan per frame (range image + intrinsics; the
///                         vehicle frame is the camera's optical frame)
/// Both: preview_topview.png, preview_frame.png and sim_info.yaml (what was generated, frames,
/// the first sensor pose in the scene frame, timings).
#include <atomic>
#include <cstdint>
#include <string>

#include "obm/config/config_node.hpp"
#include "obm/sim/lidar.hpp"
#include "obm/sim/rgbd_camera.hpp"
#include "obm/sim/scenes.hpp"
#include "obm/sim/trajectory.hpp"

namespace obm::sim {

/// `scene:` section.
struct SceneConfig {
  /// urban_grid | urban_around_trajectory | indoor_floor | indoor_room | mesh
  std::string type = "urban_grid";
  UrbanSceneParams urban;
  IndoorSceneParams indoor;
  double sensor_height = 1.73;  ///< [m] urban_around_trajectory: LiDAR above the road
  double floor_z = 0.0;         ///< [m] indoor_room: floor height in the trajectory's frame
  std::string mesh_file;        ///< mesh: OFF / PLY / OBJ
  double mesh_scale = 1.0;      ///< mesh: multiplies the coordinates
};

/// `sensor:` section.
struct SensorConfig {
  std::string type = "lidar";  ///< lidar | rgbd
  LidarParams lidar;
  RgbdParams rgbd;
  double rate() const { return type == "lidar" ? lidar.rate_hz : rgbd.rate_hz; }
};

/// `trajectory:` section.
struct TrajectoryConfig {
  std::string type = "drive";  ///< drive | walk | kitti | tum
  DriveParams drive;
  WalkParams walk;
  std::string file;           ///< kitti / tum: the pose file
  std::string times_file;     ///< kitti: times.txt ("" = 0.1 s steps)
  std::string calib_file;     ///< kitti: calib.txt with Tr ("" = KITTI 00's Tr)
  std::size_t max_poses = 0;  ///< kitti / tum: keep the first poses (0 = all)
  /// [s] drive / walk / kitti: the first frame's time stamp (sequence time + this). UNIX time
  /// of 2020-09-13 by default, so that rawlog time stamps are ordinary dates; TUM files keep
  /// their own stamps.
  double start_time = 1600000000.0;
};

/// `output:` section.
struct OutputConfig {
  std::string format = "auto";  ///< kitti | tum | auto (kitti for a LiDAR, tum for RGB-D)
  bool rawlog = true;           ///< write sequence.rawlog
  bool dataset = true;          ///< write the KITTI / TUM files
  bool pictures = true;         ///< write preview_*.png
  int rawlog_compression = 1;   ///< gzip level 1–9
  double depth_scale = 5000.0;  ///< PNG units per metre (TUM: 5000)
  std::string sensor_label;     ///< rawlog sensorLabel ("" = VELODYNE / KINECT)
};

/// A whole simulation.
struct SimConfig {
  std::string name = "sim";  ///< preset name, for messages and sim_info.yaml
  std::string source;        ///< file it was read from
  std::uint64_t seed = 1;    ///< master seed; every random choice derives from it
  std::size_t frames = 0;    ///< 0 = the whole trajectory
  int threads = 0;           ///< ray-casting threads (0 = all cores)
  SceneConfig scene;
  SensorConfig sensor;
  TrajectoryConfig trajectory;
  OutputConfig output;

  /// Reads a configuration map. Paths may contain ${VAR}; ${OBM_SHARED_DATA} falls back to the
  /// source tree's ../shared/data when the variable is unset. Throws ConfigError naming the key.
  static SimConfig load(const ConfigNode& root);
  static SimConfig loadFile(const std::string& path);
  /// Re-derives the section seeds from `seed` (call after changing it).
  void applySeed();
  /// Consistency checks across sections (throws ConfigError naming the key).
  void validate() const;
};

/// Finds config/sim/NAME.yaml: in $OBM_CONFIG_DIR/sim, <exe dir>/../share/obmslam/config/sim,
/// then the source tree's config/sim. Throws ConfigError listing the folders searched and the
/// presets found when there is none. `exe_path` may be empty.
std::string findPreset(const std::string& name, const std::string& exe_path = "");

/// Names of the presets found in the search path.
std::vector<std::string> listPresets(const std::string& exe_path = "");

/// Command-line choices applied on top of a preset or config file (what obm-sim parses).
struct SimCommandLine {
  std::string preset;       ///< --preset NAME (config/sim/NAME.yaml)
  std::string config_file;  ///< --config FILE (instead of a preset)
  std::string trajectory;   ///< --trajectory FILE: a KITTI or TUM pose file (detected)
  long long frames = -1;    ///< --frames N (−1 = the config's)
  long long seed = -1;      ///< --seed S (−1 = the config's)
  int threads = -1;         ///< --threads N (−1 = the config's)
};

/// Loads the preset / config and applies the command line. Throws ConfigError naming the
/// option, key or file at fault (unknown preset, unreadable file, ...).
SimConfig resolveConfig(const SimCommandLine& cl, const std::string& exe_path = "");

/// Expands ${VAR} in a path (see SimConfig::load); `where` names the key in errors.
std::string expandPath(const std::string& value, const std::string& where);

/// What a run produced.
struct SimSummary {
  std::string out_dir;
  std::size_t frames = 0;
  std::size_t points = 0;       ///< LiDAR points or valid depth pixels, in total
  double length_m = 0.0;        ///< trajectory length
  double seconds = 0.0;         ///< wall time of the whole run
  double sensor_seconds = 0.0;  ///< of which ray casting
  std::string scene;            ///< scene description
};

/// Thrown when a run is cancelled through SimOptions::cancel.
class Cancelled : public Error {
 public:
  using Error::Error;
};

struct SimOptions {
  std::string out_dir;                        ///< destination folder
  bool overwrite = false;                     ///< replace a non-empty destination
  bool progress = true;                       ///< progress bar on stderr
  const std::atomic<bool>* cancel = nullptr;  ///< set to true to stop (→ Cancelled)
  /// Only the pictures and sim_info.yaml: simulates just the pictured frame (a quick look at
  /// what a configuration generates).
  bool preview_only = false;
};

/// The whole pipeline; the app class that obm-sim and the tests drive.
class SequenceSimulator {
 public:
  explicit SequenceSimulator(SimConfig config);

  /// Builds the scene and the trajectory (cut to `frames`, checked against the scene bounds).
  /// Throws ConfigError / IoError / FormatError naming the key or file at fault.
  void prepare();
  const GeneratedScene& scene() const;
  const Trajectory& trajectory() const;  ///< T_world_sensor per frame, after prepare()
  const SimConfig& config() const { return cfg_; }

  /// prepare() if needed, then simulates and writes everything. On any exception (or
  /// cancellation) the destination is left untouched and the temporary folder removed.
  SimSummary run(const SimOptions& options);

  ~SequenceSimulator();

 private:
  struct State;
  SimConfig cfg_;
  std::unique_ptr<State> st_;
};

}  // namespace obm::sim
