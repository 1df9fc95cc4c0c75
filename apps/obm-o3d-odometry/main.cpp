// obm-o3d-odometry: Open3D's classical RGB-D odometry on the RGB-D folders obm-map reads, the
// peer of obm-map's indoor runs in scripts/bench_slam.sh. The Open3D calls are in odometry.cpp;
// this file parses the command line, opens the sequence and writes the outputs.
#include <CLI/CLI.hpp>
#include <cmath>
#include <filesystem>
#include <iomanip>
#include <iostream>
#include <limits>
#include <nlohmann/json.hpp>
#include <sstream>
#include <string>
#include <vector>

#include "../common/cli.hpp"
#include "obm/core/atomic_file.hpp"
#include "obm/core/errors.hpp"
#include "obm/core/log.hpp"
#include "obm/core/timer.hpp"
#include "obm/eval/trajectory_metrics.hpp"
#include "obm/io/dataset_kind.hpp"
#include "obm/io/rgbd.hpp"
#include "obm/io/trajectory.hpp"
#include "odometry.hpp"

namespace fs = std::filesystem;

namespace {

constexpr const char* kLog = "obm-o3d-odometry";

/// The RGB-D folder as obm-map opens it (RgbdSequence::open: any layout, Open3D intrinsics).
obm::io::RgbdSequence openSequence(const std::string& input, const std::string& ground_truth,
                                   double max_time_difference, std::string& kind_name) {
  if (!ground_truth.empty() && !fs::is_regular_file(ground_truth))
    throw obm::IoError("ground-truth file '" + ground_truth + "' does not exist");
  kind_name = obm::io::toString(obm::io::detectDatasetKind(input));
  obm::io::RgbdSequenceOptions ro;
  ro.max_time_difference = max_time_difference;
  ro.groundtruth_path = ground_truth;
  return obm::io::RgbdSequence::open(input, ro);
}

nlohmann::json num(double v) { return std::isfinite(v) ? nlohmann::json(v) : nlohmann::json(); }

std::string fixed(double v, int precision) {
  std::ostringstream os;
  os << std::fixed << std::setprecision(precision) << v;
  return os.str();
}

}  // namespace

int main(int argc, char** argv) {
  // Open3D's loops use OpenMP: its waiting workers spin briefly, as in the project's own apps.
  obm::apps::useFastMathLibraries(argv);
  CLI::App app{
      "obm-o3d-odometry: Open3D's classical frame-to-frame RGB-D odometry on an RGB-D folder, the "
      "peer of obm-map's indoor runs (scripts/bench_slam.sh). Methods: hybrid (Open3D's "
      "ComputeRGBDOdometry with the hybrid photometric + depth term of Steinbruecker / Kerl), "
      "color (photometric term only) and colored_icp (Open3D's coloured ICP between voxel-down-"
      "sampled coloured clouds, coarse to fine). Each estimate starts from the previous frame's "
      "motion (constant velocity); a frame whose estimate fails keeps that guess and is counted. "
      "Writes to OUT/: trajectory_tum.txt (camera optical frame, first frame = identity, the "
      "depth time stamps; the convention of obm-map's) and metrics.json (frames, failures, wall "
      "time, frames/s, method, and ATE / RPE when the input has ground truth).\n"
      "Inputs: TUM RGB-D (as obm-sim writes it), ICL-NUIM, 7-Scenes or Redwood / Open3D "
      "(depth/, color/, camera_primesense.json, trajectory.log) folders, PNG or JPEG; a frame "
      "without a colour image (or with an unreadable one) is skipped and named, and listed in "
      "metrics.json.\nCtrl-C stops after the current frame and writes the frames processed so far."};
  std::string input, out_dir, ground_truth, method_text = "hybrid", init_text = "velocity",
                                            log_level;
  std::size_t max_frames = 0;
  double depth_min = 0.3, depth_max = 4.0, max_time_difference = 0.02, lambda_geometric = 0.968;
  std::vector<double> voxels{0.04, 0.02, 0.01};
  std::vector<int> iterations{50, 30, 14};
  bool quiet = false;
  app.add_option("-i,--input", input, "RGB-D folder (TUM RGB-D, ICL-NUIM, 7-Scenes, Redwood)")
      ->required();
  app.add_option("-o,--out", out_dir, "output folder (created; files replaced atomically)")
      ->required();
  app.add_option("-m,--method", method_text,
                 "hybrid, color or colored_icp [default: hybrid]");
  app.add_option("-n,--max-frames", max_frames, "stop after this many frames, 0 = all [default: 0]");
  app.add_option("-g,--gt", ground_truth,
                 "ground truth in TUM format, associated by time stamp [default: the input's "
                 "own, if any]");
  app.add_option("--init", init_text,
                 "starting guess of each estimate: velocity (the previous motion) or identity "
                 "[default: velocity]");
  app.add_option("--depth-min", depth_min,
                 "[m] nearer depth is ignored [default: 0.3, as config/map_indoor.yaml]");
  app.add_option("--depth-max", depth_max,
                 "[m] farther depth is ignored [default: 4.0, as config/map_indoor.yaml]");
  app.add_option("--icp-voxels", voxels,
                 "colored_icp: voxel size of each level, coarse to fine [m] [default: 0.04 0.02 "
                 "0.01]")
      ->expected(1, 8);
  app.add_option("--icp-iterations", iterations,
                 "colored_icp: iteration cap of each level [default: 50 30 14]")
      ->expected(1, 8);
  app.add_option("--icp-lambda-geometric", lambda_geometric,
                 "colored_icp: weight of the geometric term against the photometric one, 0..1 "
                 "[default: 0.968, Open3D's]");
  app.add_option("--max-time-difference", max_time_difference,
                 "[s] association of depth, colour and ground truth time stamps (TUM layouts) "
                 "[default: 0.02]");
  app.add_flag("-q,--quiet", quiet, "no progress bar");
  obm::apps::addLogLevelOption(app, log_level, "warn");
  CLI11_PARSE(app, argc, argv);

  return obm::apps::runMain("obm-o3d-odometry", [&] {
    const obm::LogLevel level = obm::parseLogLevel(log_level);
    obm::setLogLevel(level);
    obm::o3d::setOpen3dVerbosity(level);
    obm::o3d::OdometryOptions o;
    o.method = obm::o3d::parseMethod(method_text, "--method");
    o.init = obm::o3d::parseInitGuess(init_text, "--init");
    o.depth_min = depth_min;
    o.depth_max = depth_max;
    o.icp_voxels = voxels;
    o.icp_iterations = iterations;
    o.icp_lambda_geometric = lambda_geometric;
    o.max_frames = max_frames;
    o.progress = !quiet;

    const obm::Timer wall;
    std::string kind;
    const obm::io::RgbdSequence seq =
        openSequence(input, ground_truth, max_time_difference, kind);
    if (seq.size() < 1) throw obm::IoError("input '" + input + "': no depth frame");
    obm::ensureDirectory(out_dir);
    const fs::path out(out_dir);

    o.cancel = &obm::apps::installCancelHandler();
    const obm::o3d::OdometryRun run = obm::o3d::runOdometry(seq, o);
    const std::size_t n = run.T_world_camera.size();
    if (n == 0 && !run.skipped_frames.empty())
      throw obm::IoError("input '" + input + "': none of its " +
                         std::to_string(run.skipped_frames.size()) +
                         " frame(s) could be read; the first: " + run.skip_reasons.front());
    const std::string traj_path = (out / "trajectory_tum.txt").string();
    obm::io::writeTumTrajectory(traj_path, obm::io::stampPoses(run.T_world_camera, run.stamps));

    // Ground truth of the frames that have one (the layout's, or --gt associated by time).
    obm::eval::PoseList est, ref;
    for (std::size_t k = 0; k < n; ++k)
      if (const obm::io::RgbdFrame& f = seq.frame(run.frames[k]); f.has_pose) {
        est.push_back(run.T_world_camera[k]);
        ref.push_back(f.T_world_camera);
      }
    const double nan = std::numeric_limits<double>::quiet_NaN();
    double ate = nan, rpe_t = nan, rpe_r = nan;
    if (est.size() >= 3) {
      ate = obm::eval::absoluteTrajectoryError(ref, est, obm::eval::Alignment::SE3).rmse;
      const auto rpe = obm::eval::relativePoseError(ref, est);
      if (rpe.n_pairs > 0) {
        rpe_t = rpe.trans_rmse;
        rpe_r = rpe.rot_rmse_deg;
      }
    }

    const double wall_s = wall.seconds();
    const double fps = wall_s > 0.0 ? static_cast<double>(n) / wall_s : 0.0;
    nlohmann::json j;
    j["method"] = obm::o3d::toString(o.method);
    j["init"] = obm::o3d::toString(o.init);
    j["input"] = input;
    j["dataset_kind"] = kind;
    j["frames"] = n;
    j["failures"] = run.failed_frames.size();
    j["failed_frames"] = run.failed_frames;
    j["skipped"] = run.skipped_frames.size();
    j["skipped_frames"] = run.skipped_frames;
    j["wall_s"] = wall_s;
    j["frames_per_second"] = fps;
    j["read_s"] = run.read_s;
    j["odometry_s"] = run.odometry_s;
    j["depth_min_m"] = o.depth_min;
    j["depth_max_m"] = o.depth_max;
    j["depth_scale"] = seq.depthScale();
    if (o.method == obm::o3d::Method::ColoredIcp) {
      j["icp_voxels_m"] = o.icp_voxels;
      j["icp_iterations"] = o.icp_iterations;
      j["icp_lambda_geometric"] = o.icp_lambda_geometric;
    }
    j["frames_evaluated"] = est.size();
    j["ate_rmse_m"] = num(ate);
    j["rpe_trans_rmse_m"] = num(rpe_t);
    j["rpe_rot_rmse_deg"] = num(rpe_r);
    j["interrupted"] = run.interrupted;
    obm::writeTextAtomically((out / "metrics.json").string(), j.dump(2) + "\n");

    std::cout << "method          " << obm::o3d::toString(o.method) << " (init "
              << obm::o3d::toString(o.init) << ")\n"
              << "frames          " << n << ", failures " << run.failed_frames.size()
              << ", skipped " << run.skipped_frames.size() << "\n"
              << "speed           " << fixed(fps, 2) << " frames/s (" << fixed(wall_s, 1)
              << " s)\n";
    if (std::isfinite(ate))
      std::cout << "ATE             " << fixed(ate, 4) << " m (" << est.size() << " frames)\n"
                << "RPE (1 frame)   " << fixed(rpe_t, 4) << " m, " << fixed(rpe_r, 4)
                << " deg\n";
    std::cout << "outputs         " << traj_path << ", " << (out / "metrics.json").string()
              << "\n";
    if (!run.failed_frames.empty())
      OBM_LOG_WARN(kLog, run.failed_frames.size()
                             << " frame(s) failed, first: frame " << run.failed_frames.front()
                             << " (" << run.failure_reasons.front() << ")");
    if (!run.skipped_frames.empty())
      OBM_LOG_WARN(kLog, run.skipped_frames.size()
                             << " frame(s) skipped (left out of the trajectory), first: "
                             << run.skip_reasons.front());
    if (run.interrupted) {
      std::cerr << "obm-o3d-odometry: interrupted; wrote the " << n
                << " frames processed so far to '" << out_dir << "'\n";
      return 130;
    }
    return 0;
  });
}
