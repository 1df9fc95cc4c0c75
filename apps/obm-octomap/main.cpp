// obm-octomap: builds an OctoMap .bt / .ot from a sequence and a trajectory (docs/obm-octomap.md).
#include <CLI/CLI.hpp>
#include <iostream>
#include <sstream>

#include "../common/cli.hpp"
#include "obm/config/config_node.hpp"
#include "obm/core/errors.hpp"
#include "obm/core/log.hpp"
#include "obm/slam/octomap_exporter.hpp"

namespace {
std::string fmt(double v) {
  std::ostringstream os;
  os << v;
  return os.str();
}
}  // namespace

int main(int argc, char** argv) {
  using obm::mapping::MappingParams;
  const MappingParams d;
  CLI::App app{
      "obm-octomap: integrates the scans of a sequence at the poses of a trajectory into an "
      "OctoMap occupancy octree and writes it as .bt (binary, maximum likelihood) or .ot (full "
      "probabilities, colours), optionally with a top-view PNG.\n"
      "Inputs: a KITTI odometry folder (velodyne/*.bin, calib.txt, times.txt), an RGB-D folder "
      "(TUM RGB-D, ICL-NUIM, 7-Scenes, Redwood) or an MRPT .rawlog.\n"
      "Trajectories: KITTI format (12 numbers per line, one pose per frame; for KITTI folders "
      "camera-0 poses like the dataset's poses.txt, converted to the LiDAR with calib.txt's Tr) "
      "or TUM format (t tx ty tz qx qy qz qw: sensor poses, associated by time stamp), or an "
      "obm-map output folder holding trajectory_kitti.txt / trajectory_tum.txt.\n"
      "Ctrl-C stops after the current scan and writes the map integrated so far."};
  obm::slam::ExporterOptions opt;
  std::string format = "auto", config, log_level;
  double resolution = -1.0, max_range = -1.0, min_range = -1.0, voxel = -1.0;
  bool quiet = false, no_discretize = false;
  app.add_option("-i,--input", opt.input, "sequence folder (KITTI or RGB-D) or MRPT .rawlog")
      ->required();
  app.add_option("-t,--trajectory", opt.trajectory,
                 "trajectory file (KITTI or TUM format) or an obm-map output folder")
      ->required();
  app.add_option("-o,--out", opt.output,
                 "map to write: MAP.bt (binary, maximum likelihood) or MAP.ot (full "
                 "probabilities; colours with --color); written atomically")
      ->required();
  app.add_option("--format", format,
                 "trajectory format: kitti, tum or auto (12 columns = kitti, 8 = tum) "
                 "[default: auto]");
  app.add_option("-r,--resolution", resolution,
                 "leaf voxel edge [m] [default: " + fmt(d.resolution) + "]");
  app.add_option("--max-range", max_range,
                 "beams are cast at most this far [m]; longer beams clear free space up to it "
                 "and mark no hit; 0 = unlimited [default: " +
                     fmt(d.max_range) + "]");
  app.add_option("--min-range", min_range,
                 "points nearer to the sensor are dropped [m] [default: " + fmt(d.min_range) + "]");
  app.add_option("--voxel", voxel,
                 "voxel-grid pre-filter of each scan before ray casting [m], 0 = off, at most the "
                 "resolution "
                 "[default: " +
                     fmt(d.prefilter_voxel) + "]");
  app.add_flag("--no-discretize", no_discretize,
               "cast one beam per (pre-filtered) point instead of one per end cell (slower)");
  app.add_option("-n,--every", opt.every, "integrate every N-th frame [default: 1]");
  app.add_option("--png", opt.png,
                 "also write a top view (height of the highest occupied voxel per column; free "
                 "= light grey, unknown = white)");
  app.add_option("--png-z-max", opt.top_view.z_max,
                 "top view: ignore voxels above this height [m] (e.g. ceilings) [default: none]");
  app.add_flag("--color", opt.color,
               "build a ColorOcTree when the input has colour (RGB-D with colour images registered to depth, coloured "
               "rawlog clouds); the top view then shows voxel colours");
  app.add_option("--max-dt", opt.max_time_difference,
                 "TUM trajectories: largest |t_frame - t_pose| to associate [s] [default: 0.02]");
  app.add_option("--time-offset", opt.time_offset,
                 "TUM trajectories: added to the pose time stamps before association [s], e.g. "
                 "-1600000000 for UNIX-time poses of a sequence-time KITTI folder [default: 0]");
  app.add_option("--max-depth", opt.rgbd_max_depth,
                 "RGB-D inputs: drop depth beyond this [m], 0 = keep [default: 0]");
  app.add_option("-c,--config", config,
                 "YAML file with a 'mapping:' section (all MappingParams keys, see "
                 "config/octomap.yaml); flags override it");
  app.add_flag("-q,--quiet", quiet, "no progress bar");
  obm::apps::addLogLevelOption(app, log_level, "warn");
  CLI11_PARSE(app, argc, argv);

  return obm::apps::runMain("obm-octomap", [&] {
    // An obm::Error here (bad input, found before the first scan) also says that nothing was
    // written; other exceptions are runMain's "unexpected error", exit code 2.
    try {
      obm::setLogLevel(obm::parseLogLevel(log_level));
      if (!config.empty()) {
        const obm::ConfigNode root = obm::ConfigNode::loadFile(config);
        root.checkKeys({"mapping"});
        opt.mapping = MappingParams::load(root.child("mapping"));
      }
      if (resolution >= 0.0) opt.mapping.resolution = resolution;
      if (max_range >= 0.0) opt.mapping.max_range = max_range;
      if (min_range >= 0.0) opt.mapping.min_range = min_range;
      if (voxel >= 0.0) opt.mapping.prefilter_voxel = voxel;
      if (no_discretize) opt.mapping.discretize = false;
      opt.format = obm::slam::parseTrajectoryFormat(format);
      opt.top_view.use_voxel_color = opt.color;
      opt.progress = !quiet;
      opt.cancel = &obm::apps::installCancelHandler();

      obm::slam::OctomapExporter exporter(opt);
      const auto summary = exporter.run();
      std::cout << obm::slam::formatSummary(summary);
      if (summary.interrupted) {
        std::cerr << "obm-octomap: interrupted; wrote the " << summary.frames_integrated << " of "
                  << summary.frames_selected << " frames integrated so far to '" << summary.output
                  << "'\n";
        return 130;
      }
      return 0;
    } catch (const obm::Error& e) {
      std::cerr << "obm-octomap: error: " << e.what() << "\nnothing was written\n";
      return 1;
    }
  });
}
