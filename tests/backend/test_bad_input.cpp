// Bad input: clear errors with the line, nothing written on failure, atomic output.
#include <gtest/gtest.h>

#include <Eigen/Eigenvalues>
#include <filesystem>
#include <fstream>
#include <sstream>

#include "obm/backend/graph_io.hpp"
#include "obm/backend/graph_tool.hpp"
#include "obm/backend/optimizer.hpp"
#include "obm/core/errors.hpp"
#include "test_data.hpp"

using namespace obm;
using namespace obm::backend;
namespace fs = std::filesystem;

namespace {

const char* kV0 = "VERTEX_SE2 0 0 0 0\n";
const char* kV1 = "VERTEX_SE2 1 1 0 0\n";
const char* kE01 = "EDGE_SE2 0 1 1 0 0 1 0 0 1 0 1\n";

/// Reads `text` and returns the FormatError (fails the test if none is thrown).
FormatError readError(const std::string& text, const ReadOptions& o = {}) {
  std::istringstream in(text);
  try {
    readG2o(in, "bad.g2o", o);
  } catch (const FormatError& e) {
    return e;
  }
  ADD_FAILURE() << "no FormatError for:\n" << text;
  return FormatError("", 0, "");
}

void expectError(const std::string& text, std::size_t line, const std::string& words) {
  const FormatError e = readError(text);
  EXPECT_EQ(e.line(), line) << e.what();
  EXPECT_NE(std::string(e.what()).find(words), std::string::npos) << e.what();
  EXPECT_NE(std::string(e.what()).find("bad.g2o"), std::string::npos) << e.what();
}

std::size_t filesIn(const std::string& dir) {
  return std::size_t(std::distance(fs::directory_iterator(dir), fs::directory_iterator()));
}

}  // namespace

TEST(BadInput, MalformedLinesNameTheLine) {
  expectError(std::string(kV0) + "VERTEX_SE2 1 1 0\n", 2, "expects 4 fields");
  expectError(std::string(kV0) + kV1 + "EDGE_SE2 0 1 1 0 0 1 0 0 1 0 1 7\n", 3,
              "expects 11 fields");
  expectError(std::string(kV0) + "VERTEX_SE2 1 1 abc 0\n", 2, "invalid number 'abc'");
  expectError(std::string(kV0) + "VERTEX_SE2 x 1 0 0\n", 2, "invalid vertex id");
  expectError(std::string(kV0) + "VERTEX_XY 1 1 0\n", 2, "unsupported element 'VERTEX_XY'");
  expectError(std::string(kV0) + "VERTEX_SE3:QUAT 1 0 0 0 0 0 0 1\n", 2, "cannot be mixed");
  expectError(std::string(kV0) + "VERTEX_SE2 1 1 0 nan\n", 2, "non-finite");
  expectError(std::string(kV0) + "VERTEX_SE2 1 1 0 inf\n", 2, "non-finite");
  expectError("# comment only\n\n", 0, "no vertices or edges");
  expectError("VERTEX_SE3:QUAT 0 0 0 0 0 0 0 0\n", 1, "zero norm");
}

TEST(BadInput, DuplicateIdsAndMissingVertices) {
  expectError(std::string(kV0) + kV1 + "VERTEX_SE2 0 5 5 5\n", 3,
              "duplicate vertex id 0 (first defined on line 1)");
  expectError(std::string(kV0) + kV1 + kE01 + "EDGE_SE2 1 7 1 0 0 1 0 0 1 0 1\n", 4, "vertex 7");
  expectError(std::string(kV0) + kV1 + "EDGE_SE2 1 1 1 0 0 1 0 0 1 0 1\n", 3, "to itself");
  expectError(std::string(kV0) + kV1 + kE01 + "FIX 9\n", 4, "FIX names vertex 9");
}

TEST(BadInput, NonPsdInformationRejectedOrRepaired) {
  const std::string bad =
      std::string(kV0) + kV1 + "EDGE_SE2 0 1 1 0 0 1 2 0 1 0 1\n";  // [[1,2],[2,1]]
  expectError(bad, 3, "not positive semi-definite");
  ReadOptions repair;
  repair.repair = InformationRepair::Clamp;
  std::istringstream in(bad);
  const PoseGraph g = readG2o(in, "bad.g2o", repair);
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> es(g.edges2[0].information);
  EXPECT_GE(es.eigenvalues().minCoeff(), -1e-12);
  EXPECT_GT(es.eigenvalues().maxCoeff(), 1.0);  // the positive part is kept
  // NaN in the information is an error even with repair.
  std::istringstream nan_in(std::string(kV0) + kV1 + "EDGE_SE2 0 1 1 0 0 1 0 0 nan 0 1\n");
  EXPECT_THROW(readG2o(nan_in, "bad.g2o", repair), FormatError);
}

TEST(BadInput, OptimizerApiRejectsBadEdges) {
  Optimizer o;
  o.addNode(0, Pose2(0, 0, 0));
  o.addNode(1, Pose2(1, 0, 0));
  Edge2 e;
  e.from = 0;
  e.to = 2;
  EXPECT_THROW(o.addEdge(e), ContractError);
  e.to = 1;
  e.information << 1, 2, 0, 2, 1, 0, 0, 0, 1;
  EXPECT_THROW(o.addEdge(e), ContractError);
  EXPECT_THROW(o.addNode(1, Pose2(0, 0, 0)), ContractError);
  EXPECT_THROW(o.addNode(5, Isometry3d::Identity()), ContractError);  // 3D node in a 2D graph
}

TEST(BadInput, ToolWritesNothingOnFailure) {
  const std::string dir = test::scratchDir("backend_bad_input");
  const std::string in = dir + "/bad.g2o";
  {
    std::ofstream f(in);
    f << kV0 << kV1 << kE01 << "EDGE_SE2 0 1 1 0 0 1 0 0 1 0\n";  // line 4 is short
  }
  GraphToolConfig c;
  c.input = in;
  c.output = dir + "/out.g2o";
  c.report = dir + "/report.json";
  std::ostringstream log;
  try {
    GraphTool(c).run(log);
    FAIL() << "expected a FormatError";
  } catch (const FormatError& e) {
    EXPECT_EQ(e.line(), 4u);
  }
  EXPECT_FALSE(fs::exists(c.output));
  EXPECT_FALSE(fs::exists(c.report));
  EXPECT_EQ(filesIn(dir), 1u);  // no temporary left behind

  // An output folder that does not exist: IoError, nothing written.
  {
    std::ofstream f(in);
    f << kV0 << kV1 << kE01;
  }
  c.output = dir + "/no_such_dir/out.g2o";
  EXPECT_THROW(GraphTool(c).run(log), IoError);
  EXPECT_FALSE(fs::exists(c.report));
  EXPECT_EQ(filesIn(dir), 1u);

  // An existing output is replaced only on success.
  c.output = dir + "/out.g2o";
  {
    std::ofstream f(c.output);
    f << "previous\n";
  }
  {
    std::ofstream f(in);
    f << kV0 << "EDGE_SE2 0 1 1 0 0 1 0 0 1 0 1\n";  // edge to a missing vertex
  }
  EXPECT_THROW(GraphTool(c).run(log), FormatError);
  std::ifstream prev(c.output);
  std::string content;
  std::getline(prev, content);
  EXPECT_EQ(content, "previous");
  EXPECT_EQ(filesIn(dir), 2u);
}

TEST(BadInput, MissingFileIsIoError) {
  EXPECT_THROW(readG2o("/nonexistent/x.g2o"), IoError);
  EXPECT_THROW(readGraph("/tmp/whatever.txt"), IoError);
}
