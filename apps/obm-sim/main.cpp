// obm-sim: simulates LiDAR / RGB-D sequences with ground truth (see docs/obm-sim.md).
#include <CLI/CLI.hpp>
#include <iostream>

#include "../common/cli.hpp"
#include "obm/core/errors.hpp"
#include "obm/core/log.hpp"
#include "obm/sim/simulator.hpp"

int main(int argc, char** argv) {
  CLI::App app{
      "obm-sim: generates a LiDAR (KITTI layout) or RGB-D (TUM layout) sequence with ground "
      "truth by ray casting a procedural or loaded scene along a trajectory, plus an MRPT rawlog "
      "and pictures. The output folder appears only when everything was written."};
  obm::sim::SimCommandLine cl;
  std::string out, log_level;
  bool overwrite = false, quiet = false, list = false, preview = false;
  app.add_option("-p,--preset", cl.preset,
                 "preset name: config/sim/NAME.yaml, searched in $OBM_CONFIG_DIR, "
                 "<exe>/../share/obmslam/config and the source tree (see --list-presets)");
  app.add_option("-c,--config", cl.config_file, "YAML configuration file instead of a preset");
  app.add_option("-o,--out", out, "output folder (must not exist or be empty, see --overwrite)");
  app.add_option("-n,--frames", cl.frames,
                 "simulate only the first N frames [default: the config's, 0 = whole trajectory]")
      ->check(CLI::NonNegativeNumber);
  app.add_option("-s,--seed", cl.seed,
                 "master seed of the scene, trajectory and noise [default: the config's]")
      ->check(CLI::NonNegativeNumber);
  app.add_option("-t,--trajectory", cl.trajectory,
                 "pose file to drive the sensor: KITTI (12 numbers per line, camera frame, 0.1 s "
                 "apart) or TUM (t tx ty tz qx qy qz qw), detected from the file [default: the "
                 "config's; the kitti00_gt and indoor_tum_* presets read "
                 "$OBM_SHARED_DATA/...]");
  app.add_option("--threads", cl.threads, "ray-casting threads, 0 = all cores [default: 0]")
      ->check(CLI::NonNegativeNumber);
  app.add_flag("--overwrite", overwrite, "replace a non-empty output folder");
  app.add_flag("-q,--quiet", quiet, "no progress bar");
  app.add_flag("--preview", preview,
               "only the pictures (top view + one frame) and sim_info.yaml: a quick look at what "
               "the configuration generates");
  app.add_flag("--list-presets", list, "print the presets found and exit");
  obm::apps::addLogLevelOption(app, log_level, "info");
  CLI11_PARSE(app, argc, argv);

  return obm::apps::runMain("obm-sim", obm::apps::OtherExceptions::Error, [&] {
    obm::setLogLevel(obm::parseLogLevel(log_level));
    if (list) {
      for (const auto& n : obm::sim::listPresets(argv[0])) std::cout << n << "\n";
      return 0;
    }
    if (out.empty()) throw obm::ConfigError("--out: an output folder is required");
    const obm::sim::SimConfig cfg = obm::sim::resolveConfig(cl, argv[0]);
    const std::atomic<bool>& cancel = obm::apps::installCancelHandler();
    obm::sim::SequenceSimulator sim(cfg);
    obm::sim::SimOptions opt;
    opt.out_dir = out;
    opt.overwrite = overwrite;
    opt.progress = !quiet;
    opt.cancel = &cancel;
    opt.preview_only = preview;
    obm::sim::SimSummary sum;
    try {
      sum = sim.run(opt);
    } catch (const obm::sim::Cancelled& e) {
      std::cerr << "obm-sim: " << e.what() << "; nothing was written\n";
      return 130;
    }
    if (preview)
      std::cout << "obm-sim: preview of a " << sum.frames << "-frame sequence (" << sum.length_m
                << " m of trajectory) -> " << sum.out_dir << "\n";
    else
      std::cout << "obm-sim: " << sum.frames << " frames, " << sum.points << " points, "
                << sum.length_m << " m of trajectory -> " << sum.out_dir << "\n";
    return 0;
  });
}
