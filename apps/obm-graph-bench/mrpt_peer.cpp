// MRPT graph-slam --levmarq as a subprocess (see peers.hpp).
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <regex>
#include <sstream>

#include "obm/backend/graph_io.hpp"
#include "obm/core/errors.hpp"
#include "obm/core/timer.hpp"
#include "peers.hpp"

namespace obm::bench {
namespace {

/// "2.0ms", "450.0us", "1.2 s" (the unit may be a separate token) → seconds.
double parseDuration(const std::string& value, const std::string& unit) {
  const double v = std::stod(value);
  if (unit == "ns") return v * 1e-9;
  if (unit == "us") return v * 1e-6;
  if (unit == "ms") return v * 1e-3;
  return v;
}

std::string run(const std::string& cmd, double& wall_s, int& status) {
  Timer t;
  FILE* p = popen(cmd.c_str(), "r");
  if (!p) throw IoError("cannot run '" + cmd + "'");
  std::string out;
  char buf[4096];
  std::size_t n;
  while ((n = fread(buf, 1, sizeof buf, p)) > 0) out.append(buf, n);
  status = pclose(p);
  wall_s = t.seconds();
  return out;
}

}  // namespace

PeerResult solveMrpt(const backend::PoseGraph& graph, const std::string& dir,
                     const std::string& exe) {
  PeerResult res;
  res.solution = graph;
  const std::string in = dir + "/mrpt_in.graph", out = dir + "/mrpt_out.graph";
  std::filesystem::remove(out);
  backend::writeToro(graph, in);
  const std::string cmd = exe + " --levmarq " + (graph.is3D() ? "--3d" : "--2d") + " -i '" + in +
                          "' -o '" + out + "' 2>&1";
  int status = 0;
  const std::string log = run(cmd, res.wall_s, status);
  if (status != 0 || !std::filesystem::exists(out)) {
    res.note = "graph-slam failed (status " + std::to_string(status) + ")";
    return res;
  }
  // Timing: "[graph-slam] Took: 00.004s" (Dijkstra) and the CTimeLogger line
  // "optimize_graph_spa_levmarq (entire)   1   2.0 s   2.0 s   2.0 s   2.0 s" (last = total).
  const std::regex took(R"(Took:\s*(?:(\d+):)?([0-9.]+)s)");
  const std::regex entire(
      R"(optimize_graph_spa_levmarq \(entire\).*\s([0-9.]+)\s?(ns|us|ms|s)\s*$)");
  const std::regex iter(R"(Iter:\s*(\d+))");
  std::istringstream ls(log);
  std::string line;
  double t = 0.0;
  int max_iter = -1;
  while (std::getline(ls, line)) {
    std::smatch m;
    if (std::regex_search(line, m, took))
      t += (m[1].matched ? 60.0 * std::stod(m[1]) : 0.0) + std::stod(m[2]);
    if (std::regex_search(line, m, entire)) t += parseDuration(m[1], m[2]);
    if (std::regex_search(line, m, iter)) max_iter = std::max(max_iter, std::stoi(m[1]));
  }
  res.time_s = t;
  res.iterations = max_iter + 1;
  // graph-slam writes its result as text with 6 significant digits: VERTEX_SE2 / VERTEX3 lines.
  std::ifstream f(out);
  std::size_t read = 0;
  while (std::getline(f, line)) {
    std::istringstream s(line);
    std::string tag;
    long long id;
    if (!(s >> tag >> id)) continue;
    if (graph.is3D() && tag == "VERTEX3") {
      Eigen::Vector3d t3, rpy;
      s >> t3.x() >> t3.y() >> t3.z() >> rpy.x() >> rpy.y() >> rpy.z();
      auto it = res.solution.nodes3.find(id);
      if (s && it != res.solution.nodes3.end()) {
        it->second.T_world_node = backend::Pose3(t3, backend::quaternionFromRpy(rpy));
        ++read;
      }
    } else if (!graph.is3D() && (tag == "VERTEX_SE2" || tag == "VERTEX2")) {
      double x, y, th;
      s >> x >> y >> th;
      auto it = res.solution.nodes2.find(id);
      if (s && it != res.solution.nodes2.end()) {
        it->second.T_world_node = Pose2(x, y, th);
        ++read;
      }
    }
  }
  res.ok = read == graph.numNodes();
  res.note = res.ok ? "ok"
                    : "read " + std::to_string(read) + " of " + std::to_string(graph.numNodes()) +
                          " poses";
  return res;
}

}  // namespace obm::bench
