#include "obm/io/redwood_log.hpp"

#include <cmath>
#include <limits>
#include <ostream>

#include "obm/core/atomic_file.hpp"
#include "obm/core/errors.hpp"
#include "text_lines.hpp"

namespace obm::io {

namespace {

/// One metadata line + an N×N matrix, as read.
template <int N>
struct Block {
  int meta[3] = {0, 0, 0};
  Eigen::Matrix<double, N, N> M;
  std::size_t line = 0;  ///< line of the metadata
};

int toInt(std::string_view tok, const std::string& path, std::size_t line) {
  const long long v = txt::parseInt(tok, path, line, "a metadata entry");
  if (v < std::numeric_limits<int>::min() || v > std::numeric_limits<int>::max())
    throw FormatError(path, line, "metadata entry '" + std::string(tok) + "' out of range");
  return static_cast<int>(v);
}

/// Reads items of (metadata line, N matrix rows); blank lines between items are allowed.
template <int N>
std::vector<Block<N>> readBlocks(const std::string& path) {
  txt::LineReader reader(path);
  std::vector<Block<N>> out;
  std::string line;
  int row = -1;  // -1: expecting metadata; 0..N-1: expecting matrix row
  Block<N> cur;
  while (reader.next(line)) {
    if (txt::isBlank(line)) continue;
    const auto tok = txt::tokenize(line);
    const std::size_t ln = reader.lineNumber();
    if (row < 0) {
      if (tok.size() != 3)
        throw FormatError(path, ln,
                          "expected a metadata line of 3 integers, got " +
                              std::to_string(tok.size()) + " fields");
      for (int k = 0; k < 3; ++k) cur.meta[k] = toInt(tok[static_cast<std::size_t>(k)], path, ln);
      cur.line = ln;
      row = 0;
      continue;
    }
    if (tok.size() != static_cast<std::size_t>(N))
      throw FormatError(path, ln,
                        "expected " + std::to_string(N) + " numbers in matrix row " +
                            std::to_string(row + 1) + ", got " + std::to_string(tok.size()));
    for (int c = 0; c < N; ++c) {
      const double v =
          txt::parseDouble(tok[static_cast<std::size_t>(c)], path, ln, "a matrix entry");
      if (!std::isfinite(v)) throw FormatError(path, ln, "non-finite matrix entry");
      cur.M(row, c) = v;
    }
    if (++row == N) {
      out.push_back(cur);
      row = -1;
    }
  }
  if (row >= 0)
    throw FormatError(path, reader.lineNumber(),
                      "file ends inside the item starting at line " + std::to_string(cur.line) +
                          " (" + std::to_string(row) + " of " + std::to_string(N) +
                          " matrix rows)");
  return out;
}

std::string formatMeta(int i, int j, int n) {
  return std::to_string(i) + '\t' + std::to_string(j) + '\t' + std::to_string(n) + '\n';
}

template <typename Matrix>
void writeMatrix(std::ostream& os, const Matrix& M) {
  for (int r = 0; r < M.rows(); ++r) {
    for (int c = 0; c < M.cols(); ++c) os << (c ? " " : "") << txt::formatExact(M(r, c));
    os << '\n';
  }
}

}  // namespace

std::vector<RedwoodLogEntry> readRedwoodLog(const std::string& path) {
  std::vector<RedwoodLogEntry> out;
  for (const auto& b : readBlocks<4>(path)) {
    const Eigen::RowVector4d last = b.M.row(3);
    if ((last - Eigen::RowVector4d(0, 0, 0, 1)).cwiseAbs().maxCoeff() > 1e-6)
      throw FormatError(path, b.line + 4, "last matrix row must be '0 0 0 1'");
    RedwoodLogEntry e;
    e.i = b.meta[0];
    e.j = b.meta[1];
    e.n = b.meta[2];
    e.T.linear() = b.M.template topLeftCorner<3, 3>();
    e.T.translation() = b.M.template topRightCorner<3, 1>();
    out.push_back(e);
  }
  return out;
}

void writeRedwoodLog(const std::string& path, const std::vector<RedwoodLogEntry>& entries) {
  writeFileAtomically(path, [&](std::ostream& os) {
    for (const auto& e : entries) {
      os << formatMeta(e.i, e.j, e.n);
      Eigen::Matrix4d M = Eigen::Matrix4d::Identity();
      M.topLeftCorner<3, 3>() = e.T.linear();
      M.topRightCorner<3, 1>() = e.T.translation();
      writeMatrix(os, M);
    }
  });
}

std::vector<Isometry3d> readRedwoodTrajectory(const std::string& path) {
  std::vector<Isometry3d> out;
  for (const auto& e : readRedwoodLog(path)) out.push_back(e.T);
  return out;
}

void writeRedwoodTrajectory(const std::string& path,
                            const std::vector<Isometry3d>& T_world_camera) {
  std::vector<RedwoodLogEntry> entries(T_world_camera.size());
  for (std::size_t k = 0; k < entries.size(); ++k) {
    const int id = static_cast<int>(k);
    entries[k] = {id, id, id + 1, T_world_camera[k]};
  }
  writeRedwoodLog(path, entries);
}

std::vector<FragmentPair> readFragmentPairs(const std::string& path) {
  std::vector<FragmentPair> out;
  for (const auto& e : readRedwoodLog(path)) out.push_back({e.i, e.j, e.n, e.T});
  return out;
}

void writeFragmentPairs(const std::string& path, const std::vector<FragmentPair>& pairs) {
  std::vector<RedwoodLogEntry> entries;
  entries.reserve(pairs.size());
  for (const auto& p : pairs) entries.push_back({p.id1, p.id2, p.num_fragments, p.T_id1_id2});
  writeRedwoodLog(path, entries);
}

std::vector<RedwoodInfoEntry> readRedwoodInfo(const std::string& path) {
  std::vector<RedwoodInfoEntry> out;
  for (const auto& b : readBlocks<6>(path)) {
    RedwoodInfoEntry e;
    e.i = b.meta[0];
    e.j = b.meta[1];
    e.n = b.meta[2];
    e.information = b.M;
    out.push_back(e);
  }
  return out;
}

void writeRedwoodInfo(const std::string& path, const std::vector<RedwoodInfoEntry>& entries) {
  writeFileAtomically(path, [&](std::ostream& os) {
    for (const auto& e : entries) {
      os << formatMeta(e.i, e.j, e.n);
      writeMatrix(os, e.information);
    }
  });
}

}  // namespace obm::io
