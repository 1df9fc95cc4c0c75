// obm-octomap-bench: integration speed of obm::mapping::OccupancyMap on real LiDAR scans (the
// KITTI HDL-64 sample by default), for a table of mapping settings. Prints a Markdown table.
#include <time.h>

#include <CLI/CLI.hpp>
#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <iomanip>
#include <iostream>
#include <sstream>
#include <string>
#include <vector>

#include "../common/cli.hpp"
#include "../common/paths.hpp"
#include "obm/core/errors.hpp"
#include "obm/core/log.hpp"
#include "obm/core/timer.hpp"
#include "obm/io/kitti.hpp"
#include "obm/mapping/occupancy_map.hpp"

namespace {

struct Variant {
  std::string name;
  bool batch_update;  ///< false: OctoMap's own insertPointCloud
  double prefilter_voxel;
  bool discretize;
  double max_range;
};

std::string num(double v, int precision) {
  std::ostringstream os;
  os << std::fixed << std::setprecision(precision) << v;
  return os.str();
}

/// [ms] CPU time of the calling thread: unlike wall time, it does not count the time the thread
/// waits for a core on a busy machine.
double threadCpuMs() {
  timespec ts{};
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
  return 1e3 * static_cast<double>(ts.tv_sec) + 1e-6 * static_cast<double>(ts.tv_nsec);
}

std::string defaultScans() {
  if (const char* env = std::getenv("OBM_SHARED_DATA"))
    return std::string(env) + "/kitti/hdl64_sample";
  return obm::apps::sourceDir() + "/../shared/data/kitti/hdl64_sample";
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{
      "obm-octomap-bench: measures OccupancyMap insertion speed (ms per scan, scans/s) on real "
      "LiDAR scans for several settings: with and without voxel pre-filter, discretised end "
      "points, max range. Scans are inserted at the identity pose, in order, into a fresh map "
      "per setting and repetition."};
  std::string scans_dir = defaultScans();
  double resolution = 0.2;
  int repeat = 3;
  std::size_t max_scans = 0;
  app.add_option("--scans", scans_dir,
                 "folder of KITTI velodyne .bin scans [default: ../shared/data/kitti/hdl64_sample "
                 "or $OBM_SHARED_DATA/kitti/hdl64_sample]");
  app.add_option("--resolution", resolution, "map resolution [m] [default: 0.2]");
  app.add_option("--repeat", repeat, "repetitions of each setting (best is kept) [default: 3]");
  app.add_option("--max-scans", max_scans, "use at most N scans (0 = all) [default: 0]");
  CLI11_PARSE(app, argc, argv);

  return obm::apps::runMain("obm-octomap-bench", obm::apps::OtherExceptions::Error, [&] {
    obm::setLogLevel(obm::LogLevel::Warn);
    std::vector<std::string> files;
    for (const auto& e : std::filesystem::directory_iterator(scans_dir))
      if (e.path().extension() == ".bin") files.push_back(e.path().string());
    std::sort(files.begin(), files.end());
    if (max_scans > 0 && files.size() > max_scans) files.resize(max_scans);
    if (files.empty()) throw obm::IoError("no .bin scans in '" + scans_dir + "'");
    std::vector<obm::PointCloud> scans;
    std::size_t points = 0;
    for (const auto& f : files) {
      scans.push_back(obm::io::readKittiVelodyne(f));
      points += scans.back().size();
    }
    std::cout << "scans: " << scans.size() << " from " << scans_dir << ", mean "
              << points / scans.size() << " points, resolution " << resolution << " m, best of "
              << repeat << "\n\n";

    const obm::mapping::MappingParams d;
    const std::vector<Variant> variants{
        {"OctoMap insertPointCloud, one ray per point", false, 0.0, false, 50.0},
        {"OctoMap insertPointCloud, discretize", false, 0.0, true, 50.0},
        {"OctoMap insertPointCloud, pre-voxel 0.1 m", false, 0.1, false, 50.0},
        {"OctoMap insertPointCloud, pre-voxel 0.1 m + discretize", false, 0.1, true, 50.0},
        {"batch, one ray per point", true, 0.0, false, 50.0},
        {"batch, discretize", true, 0.0, true, 50.0},
        {"batch, pre-voxel 0.1 m", true, 0.1, false, 50.0},
        {"batch, pre-voxel 0.1 m + discretize", true, 0.1, true, 50.0},
        {"batch, pre-voxel 0.2 m + discretize", true, 0.2, true, 50.0},
        {"batch, discretize", true, 0.0, true, 30.0},
        {"batch, discretize", true, 0.0, true, 80.0},
        {"defaults (MappingParams{})", d.batch_update, d.prefilter_voxel, d.discretize,
         d.max_range},
    };
    std::cout << "| setting | pre-voxel [m] | discretize | max range [m] | beams/scan | ms/scan "
                 "(mean) | ms/scan (max) | CPU ms/scan | scans/s | leaves | memory [MiB] |\n";
    std::cout << "|---|---|---|---|---|---|---|---|---|---|---|\n";
    for (const Variant& v : variants) {
      double best_mean = 1e300, best_max = 0.0, best_cpu = 1e300;
      std::size_t rays = 0;
      obm::mapping::MapStats stats;
      for (int r = 0; r < std::max(1, repeat); ++r) {
        obm::mapping::MappingParams p;
        p.resolution = resolution;
        p.prefilter_voxel = v.prefilter_voxel;
        p.discretize = v.discretize;
        p.max_range = v.max_range;
        p.batch_update = v.batch_update;
        obm::mapping::OccupancyMap map(p);
        double total = 0.0, worst = 0.0;
        const double cpu0 = threadCpuMs();
        rays = 0;
        for (const auto& s : scans) {
          obm::Timer t;
          const auto res = map.insert(s, obm::Isometry3d::Identity());
          const double ms = t.ms();
          total += ms;
          worst = std::max(worst, ms);
          rays += res.beams;
        }
        const double mean = total / scans.size();
        best_cpu = std::min(best_cpu, (threadCpuMs() - cpu0) / scans.size());
        if (mean < best_mean) {
          best_mean = mean;
          best_max = worst;
        }
        stats = map.stats();
      }
      std::cout << "| " << v.name << " | " << num(v.prefilter_voxel, 1) << " | "
                << (v.discretize ? "yes" : "no") << " | " << num(v.max_range, 0) << " | "
                << (rays > 0 ? std::to_string(rays / scans.size()) : std::string("n/a")) << " | "
                << num(best_mean, 1) << " | " << num(best_max, 1) << " | " << num(best_cpu, 1)
                << " | " << num(1e3 / best_mean, 2) << " | " << stats.num_leaves << " | "
                << num(static_cast<double>(stats.memory_bytes) / (1024.0 * 1024.0), 1) << " |\n";
      std::cout.flush();
    }
    return 0;
  });
}
