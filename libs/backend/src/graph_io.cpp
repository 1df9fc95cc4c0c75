// g2o and TORO/MRPT `.graph` readers and writers.
//
// g2o text format (g2o/types/slam3d/vertex_se3.cpp, edge_se3.cpp, slam2d/*): one element per line,
//   VERTEX_SE3:QUAT id x y z qx qy qz qw
//   EDGE_SE3:QUAT   from to x y z qx qy qz qw  Ω(0,0) Ω(0,1) … Ω(0,5) Ω(1,1) … Ω(5,5)   (21 values)
//   VERTEX_SE2      id x y θ
//   EDGE_SE2        from to x y θ  Ω(0,0) Ω(0,1) Ω(0,2) Ω(1,1) Ω(1,2) Ω(2,2)
//   FIX             id [id …]
// The information is the upper triangle, row-major, over g2o's error vector (t, vec q) / (x, y, θ).
//
// TORO / MRPT `.graph` (as MRPT 2.5's CNetworkOfPoses::loadFromTextFile reads it):
//   VERTEX3 id x y z roll pitch yaw           EDGE3 from to x y z roll pitch yaw  I(0,0) … I(5,5)
//   VERTEX2 id x y θ                          EDGE2 from to x y θ  I_xx I_xy I_xθ I_yy I_yθ I_θθ
// MRPT reads the EDGE2 information in the same order as g2o's EDGE_SE2 (not TORO's original
// xx xy yy θθ xθ yθ), and the EDGE3 information as the upper triangle over (x y z roll pitch yaw).
#include "obm/backend/graph_io.hpp"

#include <charconv>
#include <cstdio>
#include <fstream>
#include <sstream>
#include <string_view>
#include <unordered_map>

#include "information.hpp"
#include "obm/backend/initialization.hpp"
#include "obm/core/atomic_file.hpp"
#include "obm/core/errors.hpp"
#include "obm/core/log.hpp"

namespace obm::backend {
namespace {

constexpr const char* kLog = "backend.io";

enum class Dialect { G2o, Toro };

std::vector<std::string_view> tokenize(std::string_view line) {
  std::vector<std::string_view> out;
  std::size_t i = 0;
  const std::size_t n = line.size();
  while (i < n) {
    while (i < n && (line[i] == ' ' || line[i] == '\t' || line[i] == '\r')) ++i;
    if (i >= n) break;
    std::size_t j = i;
    while (j < n && line[j] != ' ' && line[j] != '\t' && line[j] != '\r') ++j;
    out.push_back(line.substr(i, j - i));
    i = j;
  }
  return out;
}

/// Parses one line's fields with errors naming file and line.
class LineParser {
 public:
  LineParser(const std::string& file, std::size_t line, std::vector<std::string_view> tokens)
      : file_(file), line_(line), tokens_(std::move(tokens)) {}

  [[noreturn]] void fail(const std::string& what) const { throw FormatError(file_, line_, what); }

  std::size_t size() const { return tokens_.size(); }

  void expectCount(std::size_t fields, const char* tag, const char* layout) const {
    if (tokens_.size() != fields + 1)
      fail(std::string(tag) + " expects " + std::to_string(fields) + " fields (" + layout +
           "), found " + std::to_string(tokens_.size() - 1));
  }

  NodeId id(std::size_t i, const char* what) const {
    const auto t = tokens_.at(i);
    NodeId v = 0;
    const auto r = std::from_chars(t.data(), t.data() + t.size(), v);
    if (r.ec != std::errc() || r.ptr != t.data() + t.size())
      fail(std::string("invalid ") + what + " '" + std::string(t) + "' (expected an integer id)");
    return v;
  }

  double num(std::size_t i) const {
    const auto t = tokens_.at(i);
    double v = 0.0;
    const auto r = std::from_chars(t.data(), t.data() + t.size(), v);
    if (r.ec != std::errc() || r.ptr != t.data() + t.size()) {
      // from_chars rejects a leading '+', which some writers emit.
      if (!t.empty() && t[0] == '+' && t.size() > 1) {
        const auto r2 = std::from_chars(t.data() + 1, t.data() + t.size(), v);
        if (r2.ec == std::errc() && r2.ptr == t.data() + t.size() && std::isfinite(v)) return v;
      }
      fail("invalid number '" + std::string(t) + "' in field " + std::to_string(i));
    }
    if (!std::isfinite(v))
      fail("non-finite number '" + std::string(t) + "' in field " + std::to_string(i));
    return v;
  }

 private:
  const std::string& file_;
  std::size_t line_;
  std::vector<std::string_view> tokens_;
};

template <int N>
void fillUpperTriangle(const LineParser& p, std::size_t first, Eigen::Matrix<double, N, N>& m) {
  std::size_t k = first;
  for (int r = 0; r < N; ++r)
    for (int c = r; c < N; ++c) {
      m(r, c) = p.num(k++);
      m(c, r) = m(r, c);
    }
}

template <int N>
void checkInfo(const LineParser& p, Eigen::Matrix<double, N, N>& omega, const ReadOptions& opt,
               const std::string& file, std::size_t line) {
  const auto st = detail::checkInformation<N>(omega, opt.repair == InformationRepair::Clamp);
  if (st == detail::InfoStatus::Ok) return;
  if (st == detail::InfoStatus::Repaired) {
    OBM_LOG_WARN(kLog, file << ":" << line
                            << ": information matrix is not positive semi-definite; negative "
                               "eigenvalues clamped to zero");
    return;
  }
  p.fail(std::string(detail::describe(st)));
}

Pose3 poseFromQuat(const LineParser& p, std::size_t first) {
  Pose3 pose;
  pose.t = Eigen::Vector3d(p.num(first), p.num(first + 1), p.num(first + 2));
  pose.q =
      Eigen::Quaterniond(p.num(first + 6), p.num(first + 3), p.num(first + 4), p.num(first + 5));
  if (pose.q.norm() < 1e-12) p.fail("quaternion has zero norm");
  return pose;
}

Pose3 poseFromRpy(const LineParser& p, std::size_t first) {
  Pose3 pose;
  pose.t = Eigen::Vector3d(p.num(first), p.num(first + 1), p.num(first + 2));
  const Eigen::Vector3d rpy(p.num(first + 3), p.num(first + 4), p.num(first + 5));
  pose.q = quaternionFromRpy(rpy);
  pose.rpy_from_file = rpy;
  return pose;
}

Pose2 rawPose2(double x, double y, double theta) {
  Pose2 p;  // fields set directly: θ is kept as written (the constructor would wrap it)
  p.x = x;
  p.y = y;
  p.theta = theta;
  return p;
}

PoseGraph parseGraph(std::istream& in, const std::string& name, const ReadOptions& opt,
                     Dialect dialect) {
  PoseGraph g;
  int dim = 0;  // 0 = not yet known
  std::vector<std::size_t> edge_lines;
  std::vector<std::pair<NodeId, std::size_t>> fix_lines;
  std::unordered_map<NodeId, std::size_t> vertex_line;
  bool warned_missing_info = false;

  auto setDim = [&](int d, const LineParser& p, const std::string& tag) {
    if (dim == 0) {
      dim = d;
      g.dimension = d;
    } else if (dim != d) {
      p.fail("element '" + tag + "' is " + std::to_string(d) + "D but the file is " +
             std::to_string(dim) + "D (2D and 3D elements cannot be mixed)");
    }
  };
  auto addVertexLine = [&](NodeId id, std::size_t line, const LineParser& p) {
    const auto [it, inserted] = vertex_line.emplace(id, line);
    if (!inserted)
      p.fail("duplicate vertex id " + std::to_string(id) + " (first defined on line " +
             std::to_string(it->second) + ")");
  };

  std::string line;
  std::size_t line_no = 0;
  while (std::getline(in, line)) {
    ++line_no;
    std::string_view view(line);
    const auto hash = view.find('#');
    if (hash != std::string_view::npos) view = view.substr(0, hash);
    auto tokens = tokenize(view);
    if (tokens.empty()) continue;
    const std::string tag(tokens[0]);
    LineParser p(name, line_no, std::move(tokens));

    if (dialect == Dialect::G2o && tag == "VERTEX_SE3:QUAT") {
      setDim(3, p, tag);
      p.expectCount(8, "VERTEX_SE3:QUAT", "id x y z qx qy qz qw");
      Node3 n;
      n.id = p.id(1, "vertex id");
      n.T_world_node = poseFromQuat(p, 2);
      addVertexLine(n.id, line_no, p);
      g.nodes3.emplace(n.id, n);
    } else if (dialect == Dialect::G2o && tag == "EDGE_SE3:QUAT") {
      setDim(3, p, tag);
      p.expectCount(30, "EDGE_SE3:QUAT", "from to x y z qx qy qz qw + 21 information entries");
      Edge3 e;
      e.from = p.id(1, "edge source id");
      e.to = p.id(2, "edge target id");
      e.T_from_to = poseFromQuat(p, 3);
      fillUpperTriangle<6>(p, 10, e.information);
      checkInfo<6>(p, e.information, opt, name, line_no);
      if (e.from == e.to) p.fail("edge joins vertex " + std::to_string(e.from) + " to itself");
      e.is_loop = isLoopByIds(e.from, e.to);
      g.edges3.push_back(e);
      edge_lines.push_back(line_no);
    } else if ((dialect == Dialect::G2o && tag == "VERTEX_SE2") ||
               (dialect == Dialect::Toro && (tag == "VERTEX2" || tag == "VERTEX"))) {
      setDim(2, p, tag);
      p.expectCount(4, tag.c_str(), "id x y theta");
      Node2 n;
      n.id = p.id(1, "vertex id");
      n.T_world_node = rawPose2(p.num(2), p.num(3), p.num(4));
      addVertexLine(n.id, line_no, p);
      g.nodes2.emplace(n.id, n);
    } else if ((dialect == Dialect::G2o && tag == "EDGE_SE2") ||
               (dialect == Dialect::Toro && (tag == "EDGE2" || tag == "EDGE"))) {
      setDim(2, p, tag);
      p.expectCount(11, tag.c_str(), "from to x y theta + 6 information entries");
      Edge2 e;
      e.from = p.id(1, "edge source id");
      e.to = p.id(2, "edge target id");
      e.T_from_to = rawPose2(p.num(3), p.num(4), p.num(5));
      fillUpperTriangle<3>(p, 6, e.information);
      checkInfo<3>(p, e.information, opt, name, line_no);
      if (e.from == e.to) p.fail("edge joins vertex " + std::to_string(e.from) + " to itself");
      e.is_loop = isLoopByIds(e.from, e.to);
      g.edges2.push_back(e);
      edge_lines.push_back(line_no);
    } else if (dialect == Dialect::Toro && tag == "VERTEX3") {
      setDim(3, p, tag);
      p.expectCount(7, "VERTEX3", "id x y z roll pitch yaw");
      Node3 n;
      n.id = p.id(1, "vertex id");
      n.T_world_node = poseFromRpy(p, 2);
      addVertexLine(n.id, line_no, p);
      g.nodes3.emplace(n.id, n);
    } else if (dialect == Dialect::Toro && tag == "EDGE3") {
      setDim(3, p, tag);
      if (p.size() != 9 && p.size() != 30)
        p.fail(
            "EDGE3 expects 29 fields (from to x y z roll pitch yaw + 21 information entries) "
            "or 8 (no information), found " +
            std::to_string(p.size() - 1));
      Edge3 e;
      e.from = p.id(1, "edge source id");
      e.to = p.id(2, "edge target id");
      e.T_from_to = poseFromRpy(p, 3);
      if (p.size() == 30) {
        Matrix6d info_rpy;
        fillUpperTriangle<6>(p, 9, info_rpy);
        checkInfo<6>(p, info_rpy, opt, name, line_no);
        // Change of variables to g2o's error: near Δ = I, (roll, pitch, yaw) ≈ 2·vec(q), so
        // Ω_q = Dᵀ·Ω_rpy·D with D = diag(1,1,1,2,2,2) — exact in floating point (powers of two).
        const Eigen::Matrix<double, 6, 1> d =
            (Eigen::Matrix<double, 6, 1>() << 1, 1, 1, 2, 2, 2).finished();
        e.information = d.asDiagonal() * info_rpy * d.asDiagonal();
      } else {
        // MRPT assumes unit information when it is missing.
        if (!warned_missing_info)
          OBM_LOG_WARN(kLog,
                       name << ":" << line_no << ": EDGE3 without information; assuming identity");
        warned_missing_info = true;
        const Eigen::Matrix<double, 6, 1> d =
            (Eigen::Matrix<double, 6, 1>() << 1, 1, 1, 2, 2, 2).finished();
        e.information = d.asDiagonal() * Matrix6d::Identity() * d.asDiagonal();
      }
      if (e.from == e.to) p.fail("edge joins vertex " + std::to_string(e.from) + " to itself");
      e.is_loop = isLoopByIds(e.from, e.to);
      g.edges3.push_back(e);
      edge_lines.push_back(line_no);
    } else if (tag == "FIX") {
      if (p.size() < 2) p.fail("FIX expects at least one vertex id");
      for (std::size_t i = 1; i < p.size(); ++i) fix_lines.emplace_back(p.id(i, "FIX id"), line_no);
    } else {
      p.fail("unsupported element '" + tag + "' (" +
             (dialect == Dialect::G2o
                  ? "expected VERTEX_SE3:QUAT, EDGE_SE3:QUAT, VERTEX_SE2, EDGE_SE2 or FIX"
                  : "expected VERTEX3, EDGE3, VERTEX2, EDGE2 or FIX") +
             ")");
    }
  }
  if (in.bad()) throw IoError("cannot read '" + name + "'");
  if (dim == 0) throw FormatError(name, 0, "no vertices or edges");

  const bool no_vertices = vertex_line.empty();
  auto ensureNode = [&](NodeId id, std::size_t line, const char* role) {
    if (g.hasNode(id)) return;
    if (!no_vertices)
      throw FormatError(name, line,
                        std::string("edge ") + role + " vertex " + std::to_string(id) +
                            " is not defined by any vertex line");
    if (g.is3D())
      g.nodes3.emplace(id, Node3{id, Pose3{}});
    else
      g.nodes2.emplace(id, Node2{id, Pose2{}});
  };
  for (std::size_t k = 0; k < g.numEdges(); ++k) {
    const NodeId from = g.is3D() ? g.edges3[k].from : g.edges2[k].from;
    const NodeId to = g.is3D() ? g.edges3[k].to : g.edges2[k].to;
    ensureNode(from, edge_lines[k], "source");
    ensureNode(to, edge_lines[k], "target");
  }
  for (const auto& [id, l] : fix_lines) {
    if (!g.hasNode(id))
      throw FormatError(name, l,
                        "FIX names vertex " + std::to_string(id) + " which does not exist");
    g.fixed.insert(id);
  }
  if (no_vertices) {
    OBM_LOG_INFO(kLog, name << ": no vertices; initial guess from the odometry chain");
    initializeSpanningTree(g, /*skip_loops=*/true);
  }
  return g;
}

PoseGraph readFile(const std::string& path, const ReadOptions& opt, Dialect d) {
  std::ifstream in(path);
  if (!in) throw IoError("cannot open '" + path + "' for reading");
  return parseGraph(in, path, opt, d);
}

/// %.17g: enough digits for any double to read back bit for bit.
struct NumWriter {
  std::ostream& os;
  char buf[40];
  NumWriter& operator<<(double v) {
    const int n = std::snprintf(buf, sizeof buf, " %.17g", v);
    os.write(buf, n);
    return *this;
  }
};

void writeQuatPose(NumWriter& w, const Pose3& p) {
  w << p.t.x() << p.t.y() << p.t.z() << p.q.x() << p.q.y() << p.q.z() << p.q.w();
}

/// The angles to write for a pose: the file's own when the rotation is unchanged since reading.
Eigen::Vector3d anglesFor(const Pose3& p) {
  if (p.rpy_from_file) {
    const Eigen::Quaterniond q = quaternionFromRpy(*p.rpy_from_file);
    if (q.coeffs() == p.q.coeffs()) return *p.rpy_from_file;
  }
  return rpyFromQuaternion(p.q);
}

void writeRpyPose(NumWriter& w, const Pose3& p) {
  const Eigen::Vector3d rpy = anglesFor(p);
  w << p.t.x() << p.t.y() << p.t.z() << rpy.x() << rpy.y() << rpy.z();
}

template <int N>
void writeUpper(NumWriter& w, const Eigen::Matrix<double, N, N>& m) {
  for (int r = 0; r < N; ++r)
    for (int c = r; c < N; ++c) w << m(r, c);
}

void writeGraphText(const PoseGraph& g, std::ostream& os, Dialect d) {
  NumWriter w{os, {}};
  if (g.is3D()) {
    for (const auto& [id, n] : g.nodes3) {
      os << (d == Dialect::G2o ? "VERTEX_SE3:QUAT " : "VERTEX3 ") << id;
      if (d == Dialect::G2o)
        writeQuatPose(w, n.T_world_node);
      else
        writeRpyPose(w, n.T_world_node);
      os << '\n';
    }
  } else {
    for (const auto& [id, n] : g.nodes2) {
      os << (d == Dialect::G2o ? "VERTEX_SE2 " : "VERTEX2 ") << id;
      w << n.T_world_node.x << n.T_world_node.y << n.T_world_node.theta;
      os << '\n';
    }
  }
  for (NodeId id : g.fixed) os << "FIX " << id << '\n';
  if (g.is3D()) {
    const Eigen::Matrix<double, 6, 1> dinv =
        (Eigen::Matrix<double, 6, 1>() << 1, 1, 1, 0.5, 0.5, 0.5).finished();
    for (const auto& e : g.edges3) {
      os << (d == Dialect::G2o ? "EDGE_SE3:QUAT " : "EDGE3 ") << e.from << ' ' << e.to;
      if (d == Dialect::G2o) {
        writeQuatPose(w, e.T_from_to);
        writeUpper<6>(w, e.information);
      } else {
        writeRpyPose(w, e.T_from_to);
        const Matrix6d info_rpy = dinv.asDiagonal() * e.information * dinv.asDiagonal();
        writeUpper<6>(w, info_rpy);
      }
      os << '\n';
    }
  } else {
    for (const auto& e : g.edges2) {
      os << (d == Dialect::G2o ? "EDGE_SE2 " : "EDGE2 ") << e.from << ' ' << e.to;
      w << e.T_from_to.x << e.T_from_to.y << e.T_from_to.theta;
      writeUpper<3>(w, e.information);
      os << '\n';
    }
  }
}

}  // namespace

Eigen::Quaterniond quaternionFromRpy(const Eigen::Vector3d& rpy) {
  return Eigen::AngleAxisd(rpy.z(), Eigen::Vector3d::UnitZ()) *
         Eigen::AngleAxisd(rpy.y(), Eigen::Vector3d::UnitY()) *
         Eigen::AngleAxisd(rpy.x(), Eigen::Vector3d::UnitX());
}

Eigen::Vector3d rpyFromQuaternion(const Eigen::Quaterniond& q) {
  const Eigen::Vector3d zyx = eulerZYX(q.normalized().toRotationMatrix());
  return {zyx.z(), zyx.y(), zyx.x()};
}

GraphFormat formatFromPath(const std::string& path) {
  auto endsWith = [&](const std::string& s) {
    return path.size() >= s.size() && path.compare(path.size() - s.size(), s.size(), s) == 0;
  };
  if (endsWith(".g2o")) return GraphFormat::G2o;
  if (endsWith(".graph")) return GraphFormat::Toro;
  throw IoError("'" + path + "': unknown pose-graph format (expected a .g2o or .graph file)");
}

PoseGraph readG2o(const std::string& path, const ReadOptions& o) {
  return readFile(path, o, Dialect::G2o);
}
PoseGraph readG2o(std::istream& in, const std::string& name, const ReadOptions& o) {
  return parseGraph(in, name, o, Dialect::G2o);
}
PoseGraph readToro(const std::string& path, const ReadOptions& o) {
  return readFile(path, o, Dialect::Toro);
}
PoseGraph readToro(std::istream& in, const std::string& name, const ReadOptions& o) {
  return parseGraph(in, name, o, Dialect::Toro);
}

void writeG2o(const PoseGraph& g, std::ostream& out) {
  writeGraphText(g, out, Dialect::G2o);
}
void writeToro(const PoseGraph& g, std::ostream& out) {
  writeGraphText(g, out, Dialect::Toro);
}
void writeG2o(const PoseGraph& g, const std::string& path) {
  writeFileAtomically(path, [&](std::ostream& os) { writeG2o(g, os); });
}
void writeToro(const PoseGraph& g, const std::string& path) {
  writeFileAtomically(path, [&](std::ostream& os) { writeToro(g, os); });
}

PoseGraph readGraph(const std::string& path, const ReadOptions& o) {
  return formatFromPath(path) == GraphFormat::G2o ? readG2o(path, o) : readToro(path, o);
}
void writeGraph(const PoseGraph& g, const std::string& path) {
  if (formatFromPath(path) == GraphFormat::G2o)
    writeG2o(g, path);
  else
    writeToro(g, path);
}

}  // namespace obm::backend
