// obm-convert: dataset and file-format conversions (see docs/obm-convert.md). The conversions
// themselves are library functions of obm::io (obm/io/convert.hpp); this is the command line.
#include <CLI/CLI.hpp>
#include <iostream>
#include <map>
#include <memory>
#include <optional>

#include "../common/cli.hpp"
#include "obm/core/errors.hpp"
#include "obm/core/log.hpp"
#include "obm/core/progress.hpp"
#include "obm/io/convert.hpp"
#include "obm/io/point_cloud_io.hpp"
#include "obm/io/rawlog.hpp"

namespace {

/// A progress bar created on the first report, when the total is known.
struct LazyProgress {
  std::string label, unit;
  bool enabled = true;
  std::unique_ptr<obm::ProgressBar> bar;
  obm::io::ConvertProgress callback() {
    return [this](std::size_t done, std::size_t total) {
      if (!bar) {
        bar = std::make_unique<obm::ProgressBar>(total, label, unit);
        bar->setEnabled(enabled);
      }
      bar->update(done);
    };
  }
  void finish() {
    if (bar) bar->finish();
  }
};

}  // namespace

int main(int argc, char** argv) {
  using namespace obm::io;
  CLI::App app{
      "obm-convert: converts datasets into MRPT rawlogs and TUM trajectories, and point clouds "
      "between PLY and PCD. Every output is written atomically (a failed run leaves no partial "
      "file)."};
  app.require_subcommand(1);
  std::string log_level;
  bool quiet = false;
  obm::apps::addLogLevelOption(app, log_level, "warn");
  app.add_flag("-q,--quiet", quiet, "no progress bar");

  // ---- kitti2rawlog
  std::string k_in, k_out;
  KittiToRawlogOptions k_opt;
  auto* k2r = app.add_subcommand(
      "kitti2rawlog",
      "KITTI odometry sequence folder (velodyne/*.bin, times.txt, calib.txt) -> rawlog with one "
      "CObservationPointCloud per scan (points and reflectance in the LiDAR frame, sensorPose = "
      "identity, time stamps from times.txt + --time-offset)");
  k2r->add_option("-i,--input", k_in, "sequence folder, e.g. dataset/sequences/00")->required();
  k2r->add_option("-o,--out", k_out, "rawlog to write")->required();
  k2r->add_option("--label", k_opt.sensor_label, "sensorLabel of the observations")
      ->capture_default_str();
  k2r->add_option("--time-offset", k_opt.time_offset,
                  "[s] added to times.txt (its first stamp, 0, is MRPT's 'invalid time')")
      ->capture_default_str();
  k2r->add_option("--first", k_opt.first, "first scan index")->capture_default_str();
  k2r->add_option("--count", k_opt.count, "at most this many scans [default: all]");
  k2r->add_option("--stride", k_opt.stride, "use every N-th scan")
      ->capture_default_str()
      ->check(CLI::PositiveNumber);
  k2r->add_option("--compression", k_opt.compression_level, "gzip level 1-9")
      ->capture_default_str()
      ->check(CLI::Range(1, 9));

  // ---- kitti2tum
  std::string t_in, t_out, t_frame = "lidar", t_poses;
  double t_offset = 0.0;
  auto* k2t = app.add_subcommand(
      "kitti2tum",
      "KITTI ground truth -> TUM trajectory (timestamp tx ty tz qx qy qz qw) stamped with "
      "times.txt. Poses are looked up as --poses, <seq>/poses.txt, then <seq>/../../poses/NN.txt");
  k2t->add_option("-i,--input", t_in, "sequence folder (times.txt, calib.txt)")->required();
  k2t->add_option("-o,--out", t_out, "TUM trajectory to write")->required();
  k2t->add_option("--frame", t_frame,
                  "lidar: T_world_velo (world = first LiDAR frame, via calib Tr); camera: "
                  "T_world_cam0 as in the poses file")
      ->capture_default_str()
      ->check(CLI::IsMember({"lidar", "camera"}));
  k2t->add_option("--poses", t_poses, "ground-truth poses file (KITTI format)");
  k2t->add_option("--time-offset", t_offset, "[s] added to the time stamps")->capture_default_str();

  // ---- tum2rawlog (and the other RGB-D layouts)
  std::string r_in, r_out, r_layout = "tum";
  RgbdToRawlogOptions r_opt;
  auto* r2r = app.add_subcommand(
      "tum2rawlog",
      "RGB-D sequence folder -> rawlog with one CObservation3DRangeScan per depth frame (raw "
      "depth image, its scale and the layout's intrinsics; sensorPose such that the vehicle "
      "frame is the camera's optical frame, so the sequence's ground truth is T_world_vehicle)");
  r2r->alias("rgbd2rawlog");
  r2r->add_option("-i,--input", r_in, "sequence folder (TUM: depth.txt, rgb.txt, groundtruth.txt)")
      ->required();
  r2r->add_option("-o,--out", r_out, "rawlog to write")->required();
  r2r->add_option("--layout", r_layout, "tum, iclnuim, 7scenes or redwood")->capture_default_str();
  r2r->add_option("--label", r_opt.sensor_label, "sensorLabel of the observations")
      ->capture_default_str();
  r2r->add_option("--max-dt", r_opt.sequence.max_time_difference,
                  "[s] association window of depth / colour / ground-truth stamps")
      ->capture_default_str();
  r2r->add_option("--time-offset", r_opt.time_offset,
                  "[s] added to the frame times (7scenes / redwood frames start at 0, MRPT's "
                  "'invalid time')")
      ->capture_default_str();
  r2r->add_option("--first", r_opt.first, "first frame index")->capture_default_str();
  r2r->add_option("--count", r_opt.count, "at most this many frames [default: all]");
  r2r->add_option("--stride", r_opt.stride, "use every N-th frame")
      ->capture_default_str()
      ->check(CLI::PositiveNumber);
  r2r->add_option("--compression", r_opt.compression_level, "gzip level 1-9")
      ->capture_default_str()
      ->check(CLI::Range(1, 9));

  // ---- cloud
  std::string c_in, c_out;
  bool c_ascii = false;
  auto* cloud = app.add_subcommand(
      "cloud",
      "point-cloud file (.ply, .pcd or .off) -> .ply or .pcd (x y z, intensity and colour when "
      "present; NaN / infinite points dropped)");
  cloud->add_option("-i,--input", c_in, "point cloud to read")
      ->required()
      ->check(CLI::ExistingFile);
  cloud->add_option("-o,--out", c_out, "point cloud to write (.ply or .pcd)")->required();
  cloud->add_flag("--ascii", c_ascii, "write ascii instead of binary");

  // ---- info
  std::string i_in;
  auto* info = app.add_subcommand(
      "info",
      "reads a rawlog through obm::io::RawlogReader (the reader the mapping pipeline uses) and "
      "prints what it finds: observations per class and sensor, time span, points");
  info->add_option("-i,--input", i_in, "rawlog to read")->required()->check(CLI::ExistingFile);

  CLI11_PARSE(app, argc, argv);

  return obm::apps::runMain("obm-convert", [&] {
    obm::setLogLevel(obm::parseLogLevel(log_level));
    if (*k2r) {
      LazyProgress p{"kitti2rawlog", "scans", !quiet, nullptr};
      const std::size_t n = kittiToRawlog(k_in, k_out, k_opt, p.callback());
      p.finish();
      std::cout << "wrote " << n << " point-cloud observations to " << k_out << "\n";
    } else if (*k2t) {
      const std::size_t n = kittiToTum(
          t_in, t_out, t_frame == "camera" ? KittiPoseFrame::Camera : KittiPoseFrame::Lidar,
          t_poses, t_offset);
      std::cout << "wrote " << n << " " << t_frame << " poses to " << t_out << "\n";
    } else if (*r2r) {
      r_opt.layout = parseRgbdLayout(r_layout);
      LazyProgress p{"tum2rawlog", "frames", !quiet, nullptr};
      const std::size_t n = rgbdToRawlog(r_in, r_out, r_opt, p.callback());
      p.finish();
      std::cout << "wrote " << n << " depth observations to " << r_out << "\n";
    } else if (*info) {
      RawlogReader reader(i_in);
      obm::ProgressBar bar(1000, "info", "permille");
      bar.setEnabled(!quiet);
      RawlogObservation o;
      std::map<std::string, std::size_t> per_class;
      std::size_t points = 0;
      double t0 = 0, t1 = 0;
      bool monotonic = true;
      while (reader.next(o)) {
        ++per_class[o.class_name + " '" + o.sensor_label + "'"];
        points += o.cloud.size();
        if (reader.counts().returned == 1) t0 = o.timestamp;
        if (o.timestamp < t1) monotonic = false;
        t1 = o.timestamp;
        bar.update(static_cast<std::size_t>(1000 * reader.progress()));
      }
      bar.finish();
      const auto& c = reader.counts();
      std::cout << i_in << ": " << c.objects << " objects, " << c.sensory_frames
                << " sensory frames, " << c.actions << " actions, " << c.observations
                << " observations\n";
      for (const auto& [k, n] : per_class) std::cout << "  read    " << n << " x " << k << "\n";
      for (const auto& [k, n] : c.skipped_by_class)
        std::cout << "  skipped " << n << " x " << k << "\n";
      std::cout.precision(17);
      std::cout << "  time " << t0 << " .. " << t1 << " s" << (monotonic ? "" : " (not monotonic)")
                << ", " << points << " points\n";
    } else if (*cloud) {
      const auto r = readPointCloudDetailed(c_in);
      const auto w = writePointCloud(c_out, r.cloud, !c_ascii);
      std::cout << "wrote " << w.num_written << " points to " << c_out;
      if (r.num_nonfinite_dropped)
        std::cout << " (" << r.num_nonfinite_dropped << " non-finite dropped)";
      std::cout << "\n";
    }
    return 0;
  });
}
