// obm-map: rawlog / KITTI / TUM playback mapping (docs/obm-map.md). The logic is
// obm::slam::MappingApp; this file only parses the command line.
#include <CLI/CLI.hpp>
#include <iostream>
#include <string>
#include <vector>

#include "../common/cli.hpp"
#include "obm/config/overrides.hpp"
#include "obm/core/errors.hpp"
#include "obm/core/log.hpp"
#include "obm/slam/mapping_app.hpp"

int main(int argc, char** argv) {
  obm::apps::useFastMathLibraries(argv);
  CLI::App app{
      "obm-map: plays a LiDAR or RGB-D sequence through the SLAM pipeline — preprocessing, "
      "scan-to-local-map tracking, keyframes, loop closures verified by the scan matcher "
      "(OBMNet + ICP when the model exists, else ICP), Ceres pose-graph optimisation, OctoMap "
      "integration — and writes to OUT/: trajectory_tum.txt, trajectory_kitti.txt (camera-0 "
      "poses like poses.txt for a KITTI folder), keyframes_tum.txt, graph.g2o, map.bt, map.ot, "
      "metrics.json (KITTI t_err/r_err, ATE, RPE when ground truth is given or found), "
      "timing.json, frames.csv, loops.csv, trajectory_topview.png / .svg, map_topview.png, "
      "report.html (the run as a page), and for MRPT's tools keyframes.simplemap, scene.3Dscene "
      "and trajectory_mrpt.txt.\n"
      "Inputs: a KITTI odometry folder (velodyne/*.bin, calib.txt, times.txt; ground truth "
      "poses.txt next to velodyne/ or the devkit's poses/NN.txt), an RGB-D folder (TUM RGB-D, "
      "ICL-NUIM, 7-Scenes, Redwood) or an MRPT .rawlog (ground truth groundtruth.txt next to "
      "it).\nCtrl-C stops after the current frame and writes everything processed so far."};
  obm::slam::MappingAppOptions opt;
  std::string config, log_level, matcher;
  bool quiet = false, no_map = false, no_loops = false;
  app.add_option("-c,--config", config,
                 "YAML configuration (config/map_kitti.yaml for LiDAR, config/map_indoor.yaml for "
                 "RGB-D); every key is documented in the file")
      ->required();
  app.add_option("-i,--input", opt.input,
                 "KITTI sequence folder, RGB-D folder (TUM/ICL-NUIM/7-Scenes/Redwood) or .rawlog")
      ->required();
  app.add_option("-o,--out", opt.out_dir, "output folder (created; files replaced atomically)")
      ->required();
  app.add_option("-g,--gt", opt.ground_truth,
                 "ground truth: KITTI format (12 numbers per line, camera-0 poses for a KITTI "
                 "folder, one per frame) or TUM format (associated by time stamp) [default: the "
                 "input's own, if any]");
  app.add_option("-n,--max-frames", opt.max_frames,
                 "stop after this many frames, 0 = all [default: 0]");
  app.add_option("--matcher", matcher,
                 "override matcher.type of the configuration: icp, obmnet, obmnet+icp or obmm+icp");
  std::vector<std::string> overrides;
  app.add_option("--set", overrides,
                 "override any configuration key, repeatable: --set loop_closure.min_travel=80 "
                 "--set tracking.information_scale=0.5 (the value is YAML)");
  app.add_flag("--no-loops", no_loops, "disable loop closure (odometry only)");
  app.add_flag("--no-map", no_map, "do not build the OctoMap (map.bt, map.ot, map_topview.png)");
  app.add_flag("-q,--quiet", quiet, "no progress bar");
  obm::apps::addLogLevelOption(app, log_level, "warn");
  CLI11_PARSE(app, argc, argv);

  return obm::apps::runMain("obm-map", [&] {
    obm::setLogLevel(obm::parseLogLevel(log_level));
    OBM_LOG_DEBUG("obm-map", "math libraries: " << obm::apps::mathLibrarySettings());
    auto root = obm::ConfigNode::loadFile(config);
    obm::applyOverrides(root, overrides);
    obm::slam::SlamConfig cfg = obm::slam::SlamConfig::load(root);
    if (!matcher.empty()) {
      const obm::registration::MatcherKind kind =
          obm::registration::parseMatcherKind(matcher, "--matcher");
      if (obm::registration::usesNetwork(kind) && cfg.frontend.matcher.obmnet.network.model_path.empty())
        throw obm::ConfigError("--matcher " + matcher + ": the configuration '" + config +
                               "' has no matcher.obmnet section with a model_path");
      cfg.frontend.matcher.type = kind;
    }
    if (no_loops) cfg.frontend.loop_closure.enabled = false;
    if (no_map) cfg.output.map = false;
    opt.progress = !quiet;
    opt.cancel = &obm::apps::installCancelHandler();

    obm::slam::MappingApp mapping_app(std::move(cfg), opt);
    const obm::slam::RunSummary summary = mapping_app.run();
    std::cout << obm::slam::formatSummary(summary);
    if (summary.interrupted) {
      std::cerr << "obm-map: interrupted; wrote the " << summary.frames
                << " frames processed so far to '" << opt.out_dir << "'\n";
      return 130;
    }
    return 0;
  });
}
