#pragma once
/// \file graph_io.hpp
/// Pose-graph files: g2o (`VERTEX_SE3:QUAT`, `EDGE_SE3:QUAT`, `VERTEX_SE2`, `EDGE_SE2`, `FIX`) and
/// the TORO / MRPT `.graph` text format (`VERTEX3`/`EDGE3`, `VERTEX2`/`EDGE2`, `FIX`) as MRPT 2.x
/// reads it. Numbers are written with 17 significant digits, so read → write → read gives the same
/// doubles bit for bit. Writers are atomic (temporary file + rename).
#include <iosfwd>
#include <string>

#include "obm/backend/pose_graph.hpp"

namespace obm::backend {

/// What to do with an information matrix that is not positive semi-definite.
enum class InformationRepair {
  Reject,  ///< FormatError naming the file and line (default)
  Clamp,   ///< clamp negative eigenvalues to zero and log a warning naming the line
};

/// Reader options.
struct ReadOptions {
  InformationRepair repair = InformationRepair::Reject;
};

/// File format, chosen from the extension: `.g2o` → G2o, `.graph` → Toro.
enum class GraphFormat { G2o, Toro };

/// Format of `path` by extension; throws IoError for an unknown extension.
GraphFormat formatFromPath(const std::string& path);

/// Reads a g2o file. 2D/3D is detected from the element tags (mixing them is an error). A file with
/// edges but no vertices gets an odometry-chain initial guess (spanning tree from the lowest id,
/// consecutive-id edges first). Throws IoError (cannot open) or FormatError(file, line, what) for a
/// malformed line, unknown tag, duplicate vertex id, non-finite number, edge to a missing vertex or
/// non-PSD information matrix (unless repaired, see ReadOptions).
PoseGraph readG2o(const std::string& path, const ReadOptions& options = {});
/// Same from a stream; `name` is used in error messages.
PoseGraph readG2o(std::istream& in, const std::string& name, const ReadOptions& options = {});

/// Writes g2o text (17 significant digits). Vertices by id, `FIX` lines, then edges in order.
void writeG2o(const PoseGraph& graph, std::ostream& out);
/// Writes a g2o file atomically; throws IoError.
void writeG2o(const PoseGraph& graph, const std::string& path);

/// Reads a TORO / MRPT `.graph` file. As MRPT 2.x reads it: `VERTEX3 id x y z roll pitch yaw`,
/// `EDGE3 from to x y z roll pitch yaw` + the 21 upper-triangular entries (row-major) of the
/// information over (x, y, z, roll, pitch, yaw); `VERTEX2 id x y θ`, `EDGE2 from to x y θ` + the 6
/// upper-triangular entries (row-major, I_xx I_xy I_xθ I_yy I_yθ I_θθ); R =
/// Rz(yaw)·Ry(pitch)·Rx(roll). The 3D information is converted to g2o's (t, vec q) error with the
/// Jacobian at the identity (∂(roll,pitch,yaw)/∂vec(q) = 2·I), an exact scaling by powers of two.
PoseGraph readToro(const std::string& path, const ReadOptions& options = {});
PoseGraph readToro(std::istream& in, const std::string& name, const ReadOptions& options = {});

/// Writes TORO / MRPT `.graph` text (17 significant digits).
void writeToro(const PoseGraph& graph, std::ostream& out);
void writeToro(const PoseGraph& graph, const std::string& path);

/// Reads `.g2o` or `.graph` by extension.
PoseGraph readGraph(const std::string& path, const ReadOptions& options = {});
/// Writes `.g2o` or `.graph` by extension, atomically.
void writeGraph(const PoseGraph& graph, const std::string& path);

/// Quaternion R = Rz(yaw)·Ry(pitch)·Rx(roll) of the TORO/MRPT angles (roll, pitch, yaw).
Eigen::Quaterniond quaternionFromRpy(const Eigen::Vector3d& rpy);
/// (roll, pitch, yaw) of a rotation, yaw and roll in (−π, π], pitch in [−π/2, π/2].
Eigen::Vector3d rpyFromQuaternion(const Eigen::Quaterniond& q);

}  // namespace obm::backend
