// obm-icp-bench: point-to-plane ICP between consecutive real KITTI HDL-64E scans, from the
// identity, for several voxel sizes and thread counts. Prints a Markdown table: target
// preparation (KD-tree + normals) and ICP time per pair, iterations, and the consistency of
// T_{i←i+2} with T_{i←i+1}·T_{i+1←i+2} (there is no ground truth for the sample).
#include <CLI/CLI.hpp>
#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <ctime>
#include <filesystem>
#include <iostream>
#include <sstream>

#include "obm/config/config_node.hpp"
#include "obm/core/cloud_ops.hpp"
#include "obm/core/errors.hpp"
#include "obm/core/timer.hpp"
#include "obm/io/kitti.hpp"
#include "obm/registration/icp.hpp"

using namespace obm;

namespace {

double median(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  return v.empty() ? 0.0 : v[v.size() / 2];
}

double mean(const std::vector<double>& v) {
  double s = 0;
  for (double x : v) s += x;
  return v.empty() ? 0.0 : s / double(v.size());
}

std::vector<double> parseList(const std::string& s) {
  std::vector<double> out;
  std::stringstream ss(s);
  std::string item;
  while (std::getline(ss, item, ',')) out.push_back(std::stod(item));
  if (out.empty()) throw ConfigError("empty list '" + s + "'");
  return out;
}

struct Row {
  double voxel = 0;
  int threads = 0;
  double src_pts = 0, tgt_pts = 0, prepare_ms = 0, icp_ms = 0, icp_cpu_ms = 0, iterations = 0;
  double max_cons_t = 0, max_cons_r = 0;
  int converged = 0, pairs = 0;
};

int run(int argc, char** argv) {
  CLI::App app{
      "Point-to-plane ICP benchmark on the KITTI sample scans: time per pair and iterations for\n"
      "several voxel sizes and thread counts, printed as a Markdown table."};
  std::string data;
  if (const char* env = std::getenv("OBM_SHARED_DATA"))
    data = std::string(env) + "/kitti/hdl64_sample";
  std::string voxels = "0.3,0.5", threads = "1,2", config;
  int repeats = 3, first = 0, count = 6;
  double min_range = 2.0, max_range = 100.0;
  app.add_option("--data", data,
                 "folder with 000000.bin ... (KITTI velodyne scans); default "
                 "$OBM_SHARED_DATA/kitti/hdl64_sample")
      ->capture_default_str();
  app.add_option("--voxels", voxels, "comma-separated voxel sizes [m] (source and target)")
      ->capture_default_str();
  app.add_option("--threads", threads, "comma-separated thread counts")->capture_default_str();
  app.add_option("--repeats", repeats, "runs per pair; the median time is reported")
      ->capture_default_str()
      ->check(CLI::PositiveNumber);
  app.add_option("--first", first, "index of the first scan")->capture_default_str();
  app.add_option("--count", count, "number of consecutive scans (>= 3)")
      ->capture_default_str()
      ->check(CLI::Range(3, 100000));
  app.add_option("--min-range", min_range, "crop: minimum range [m]")->capture_default_str();
  app.add_option("--max-range", max_range, "crop: maximum range [m]")->capture_default_str();
  app.add_option("--config", config,
                 "YAML file whose `icp:` map overrides the ICP parameters (voxels and threads "
                 "are still set by --voxels / --threads)");
  CLI11_PARSE(app, argc, argv);
  if (data.empty()) throw ConfigError("no --data folder and OBM_SHARED_DATA is not set");

  registration::IcpParams base;
  base.max_correspondence_distance = 1.0;
  if (!config.empty())
    base = registration::IcpParams::load(ConfigNode::loadFile(config).child("icp"));

  std::vector<PointCloud> scans;
  for (int i = first; i < first + count; ++i) {
    const std::string path = data + "/" + io::kittiScanFileName(std::size_t(i));
    scans.push_back(cropRange(io::readKittiVelodyne(path), min_range, max_range));
  }
  std::cerr << "read " << scans.size() << " scans from " << data << "\n";

  std::vector<Row> rows;
  for (double voxel : parseList(voxels)) {
    std::vector<PointCloud> down;
    for (const auto& s : scans) down.push_back(voxelDownsample(s, voxel));
    for (double th : parseList(threads)) {
      registration::IcpParams p = base;
      p.threads = int(th);
      p.source_voxel = 0.0;  // clouds are down-sampled once above
      p.target_voxel = 0.0;
      const registration::IcpMatcher icp(p);
      Row row;
      row.voxel = voxel;
      row.threads = p.threads;
      std::vector<double> prep, times, cpus, iters, srcn, tgtn;
      std::vector<Isometry3d> step;  // T_{i←i+1}
      for (std::size_t i = 0; i + 1 < down.size(); ++i) {
        std::vector<double> tp, tm, tc;
        registration::MatchResult r;
        for (int k = 0; k < repeats; ++k) {
          Timer t;
          const registration::PreparedTarget target = icp.prepare(down[i]);
          tp.push_back(t.ms());
          const std::clock_t c0 = std::clock();  // process CPU time, all threads
          r = icp.match(down[i + 1], target);
          tc.push_back(1e3 * double(std::clock() - c0) / CLOCKS_PER_SEC);
          tm.push_back(r.runtime_ms);
        }
        prep.push_back(median(tp));
        times.push_back(median(tm));
        cpus.push_back(median(tc));
        iters.push_back(r.iterations);
        srcn.push_back(double(down[i + 1].size()));
        tgtn.push_back(double(down[i].size()));
        row.converged += r.converged ? 1 : 0;
        ++row.pairs;
        step.push_back(r.T_target_source);
      }
      // Consistency over triples: ICP i←i+2 vs the composition of the two single steps.
      for (std::size_t i = 0; i + 2 < down.size(); ++i) {
        const registration::MatchResult r2 = icp.match(down[i + 2], down[i], step[i] * step[i + 1]);
        const Isometry3d D = r2.T_target_source.inverse() * (step[i] * step[i + 1]);
        row.max_cons_t = std::max(row.max_cons_t, D.translation().norm());
        row.max_cons_r = std::max(row.max_cons_r, rotationAngle(D.linear()) * kRadToDeg);
      }
      row.src_pts = mean(srcn);
      row.tgt_pts = mean(tgtn);
      row.prepare_ms = mean(prep);
      row.icp_ms = mean(times);
      row.icp_cpu_ms = mean(cpus);
      row.iterations = mean(iters);
      rows.push_back(row);
    }
  }

  std::printf(
      "| voxel [m] | threads | points (src / tgt) | prepare target [ms] | ICP wall [ms] | ICP CPU "
      "[ms] | iterations | converged | consistency max Δt [cm] / Δr [deg] |\n");
  std::printf("|---|---|---|---|---|---|---|---|---|\n");
  for (const auto& r : rows)
    std::printf("| %.2f | %d | %.0f / %.0f | %.1f | %.1f | %.1f | %.1f | %d/%d | %.2f / %.3f |\n",
                r.voxel, r.threads, r.src_pts, r.tgt_pts, r.prepare_ms, r.icp_ms, r.icp_cpu_ms,
                r.iterations, r.converged, r.pairs, 100.0 * r.max_cons_t, r.max_cons_r);
  std::printf(
      "\nPairs (i, i+1) of scans %d..%d, from the identity; times are means over pairs of the "
      "median of %d runs; CPU = process CPU time of all threads.\n",
      first, first + count - 1, repeats);
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  try {
    return run(argc, argv);
  } catch (const std::exception& e) {
    std::cerr << "obm-icp-bench: " << e.what() << "\n";
    return 1;
  }
}
