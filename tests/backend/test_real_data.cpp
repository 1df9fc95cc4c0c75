// The real benchmark graphs in ../shared/data/posegraph: reading, bit-exact round trip, and the
// obm-graph tool end to end on small ones.
#include <gtest/gtest.h>

#include <cstring>
#include <filesystem>
#include <fstream>
#include <map>
#include <nlohmann/json.hpp>
#include <sstream>

#include "obm/backend/graph_io.hpp"
#include "obm/backend/graph_tool.hpp"
#include "obm/backend/metrics.hpp"
#include "test_data.hpp"

using namespace obm;
using namespace obm::backend;

namespace {

std::string posegraph(const std::string& name) {
  return test::sharedDataDir() + "/posegraph/" + name + ".g2o";
}

/// Counts lines per tag, independently of the reader.
std::map<std::string, std::size_t> countTags(const std::string& path) {
  std::ifstream f(path);
  std::map<std::string, std::size_t> m;
  std::string line, tag;
  while (std::getline(f, line)) {
    std::istringstream ls(line);
    if (ls >> tag) ++m[tag];
  }
  return m;
}

}  // namespace

TEST(RealData, ReadsEveryBenchmarkGraph) {
  OBM_REQUIRE_SHARED_DATA("posegraph");
  const std::vector<std::pair<std::string, int>> files = {{"sphere2500", 3},
                                                          {"parking-garage", 3},
                                                          {"smallGrid3D", 3},
                                                          {"tinyGrid3D", 3},
                                                          {"sphere_bignoise_vertex3", 3},
                                                          {"intel", 2},
                                                          {"manhattan", 2},
                                                          {"ais2klinik", 2},
                                                          {"kitti_05", 2}};
  for (const auto& [name, dim] : files) {
    const auto tags = countTags(posegraph(name));
    const PoseGraph g = readG2o(posegraph(name));
    EXPECT_EQ(g.dimension, dim) << name;
    const std::string vtag = dim == 3 ? "VERTEX_SE3:QUAT" : "VERTEX_SE2";
    const std::string etag = dim == 3 ? "EDGE_SE3:QUAT" : "EDGE_SE2";
    EXPECT_EQ(g.numEdges(), tags.count(etag) ? tags.at(etag) : 0u) << name;
    if (tags.count(vtag))
      EXPECT_EQ(g.numNodes(), tags.at(vtag)) << name;
    else
      EXPECT_GT(g.numNodes(), 1u) << name << ": nodes from the edges";
    const double c = chi2(g);
    EXPECT_TRUE(std::isfinite(c)) << name;
    EXPECT_GT(c, 0.0) << name;
  }
}

TEST(RealData, RoundTripIsBitExact) {
  OBM_REQUIRE_SHARED_DATA("posegraph");
  for (const std::string name : {"parking-garage", "intel"}) {
    const PoseGraph g = readG2o(posegraph(name));
    std::stringstream s1;
    writeG2o(g, s1);
    const PoseGraph r = readG2o(s1, name);
    std::stringstream s2;
    writeG2o(r, s2);
    EXPECT_EQ(s1.str(), s2.str()) << name;
    EXPECT_EQ(chi2(g), chi2(r)) << name;  // same bits in, same χ² out
    // Every number of the file reads back identically from our output.
    if (g.is3D()) {
      for (std::size_t i = 0; i < g.edges3.size(); ++i)
        ASSERT_TRUE(g.edges3[i].information == r.edges3[i].information &&
                    g.edges3[i].T_from_to.t == r.edges3[i].T_from_to.t &&
                    g.edges3[i].T_from_to.q.coeffs() == r.edges3[i].T_from_to.q.coeffs())
            << name << " edge " << i;
    }
    // And through the TORO format (2D is exact; 3D rotations go through Euler angles).
    std::stringstream t1;
    writeToro(g, t1);
    const PoseGraph tr = readToro(t1, name);
    EXPECT_NEAR(chi2(tr), chi2(g), 1e-9 * chi2(g)) << name;
  }
}

TEST(RealData, ToolOptimisesAndReports) {
  OBM_REQUIRE_SHARED_DATA("posegraph");
  const std::string dir = test::scratchDir("backend_tool");
  for (const std::string name : {"tinyGrid3D", "intel"}) {
    GraphToolConfig c;
    c.input = posegraph(name);
    c.output = dir + "/" + name + ".g2o";
    c.report = dir + "/" + name + ".json";
    std::ostringstream log;
    const Summary s = GraphTool(c).run(log);
    EXPECT_TRUE(s.converged) << name << ": " << s.message;
    EXPECT_LT(s.final_chi2, s.initial_chi2) << name;
    EXPECT_NE(log.str().find("iter "), std::string::npos);
    std::ifstream jf(c.report);
    const auto j = nlohmann::json::parse(jf);
    for (const char* key : {"initial_chi2", "final_chi2", "iterations", "time_s", "converged"})
      EXPECT_TRUE(j.contains(key)) << key;
    EXPECT_TRUE(j["converged"].get<bool>());
    EXPECT_EQ(j["final_chi2"].get<double>(), s.final_chi2);
    // The written graph has the reported χ².
    const PoseGraph out = readG2o(c.output);
    EXPECT_NEAR(chi2(out), s.final_chi2, 1e-9 * s.final_chi2) << name;
  }
}
