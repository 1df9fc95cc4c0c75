#include "obm/io/trajectory.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <numeric>
#include <ostream>
#include <tuple>

#include "obm/core/atomic_file.hpp"
#include "obm/core/errors.hpp"
#include "text_lines.hpp"

namespace obm::io {

using txt::formatExact;

Trajectory readTumTrajectory(const std::string& path) {
  txt::LineReader reader(path);
  Trajectory out;
  std::string line;
  static const char* const kFields[8] = {"timestamp", "tx", "ty", "tz", "qx", "qy", "qz", "qw"};
  while (reader.next(line)) {
    const auto body = txt::trimLeft(line);
    // TUM file format: "The file may contain comments that have to start with '#'".
    if (body.empty() || body.front() == '#') continue;
    const auto tok = txt::tokenize(body, /*comma_is_space=*/true);
    if (tok.size() != 8)
      throw FormatError(
          path, reader.lineNumber(),
          "expected 8 numbers 'timestamp tx ty tz qx qy qz qw', got " + std::to_string(tok.size()));
    std::array<double, 8> v{};
    for (std::size_t k = 0; k < 8; ++k) {
      v[k] = txt::parseDouble(tok[k], path, reader.lineNumber(), kFields[k]);
      if (!std::isfinite(v[k]))
        throw FormatError(path, reader.lineNumber(),
                          std::string("non-finite value for ") + kFields[k]);
    }
    const Eigen::Quaterniond q(v[7], v[4], v[5],
                               v[6]);  // Eigen's constructor order is (w, x, y, z)
    if (q.norm() < 1e-12) throw FormatError(path, reader.lineNumber(), "zero quaternion");
    StampedPose p;
    p.t = v[0];
    p.T = makeIsometry(q, Eigen::Vector3d(v[1], v[2], v[3]));
    out.push_back(p);
  }
  return out;
}

void writeTumTrajectory(const std::string& path, const Trajectory& trajectory) {
  writeFileAtomically(path, [&](std::ostream& os) {
    os << "# timestamp tx ty tz qx qy qz qw\n";
    for (const auto& p : trajectory) {
      Eigen::Quaterniond q(p.T.linear());
      q.normalize();
      if (q.w() < 0) q.coeffs() = -q.coeffs();  // q and −q are the same rotation; pick one
      const Eigen::Vector3d t = p.T.translation();
      os << formatExact(p.t) << ' ' << formatExact(t.x()) << ' ' << formatExact(t.y()) << ' '
         << formatExact(t.z()) << ' ' << formatExact(q.x()) << ' ' << formatExact(q.y()) << ' '
         << formatExact(q.z()) << ' ' << formatExact(q.w()) << '\n';
    }
  });
}

std::vector<Isometry3d> readKittiTrajectory(const std::string& path) {
  txt::LineReader reader(path);
  std::vector<Isometry3d> out;
  std::string line;
  while (reader.next(line)) {
    if (txt::isBlank(line)) continue;
    const auto tok = txt::tokenize(line);
    if (tok.size() != 12)
      throw FormatError(
          path, reader.lineNumber(),
          "expected 12 numbers (row-major 3x4 [R|t]), got " + std::to_string(tok.size()));
    std::array<double, 12> v{};
    for (std::size_t k = 0; k < 12; ++k) {
      v[k] = txt::parseDouble(tok[k], path, reader.lineNumber(), "a pose matrix entry");
      if (!std::isfinite(v[k]))
        throw FormatError(path, reader.lineNumber(),
                          "non-finite pose matrix entry " + std::to_string(k + 1));
    }
    out.push_back(fromRowMajor3x4(v));
  }
  return out;
}

void writeKittiTrajectory(const std::string& path, const std::vector<Isometry3d>& poses) {
  writeFileAtomically(path, [&](std::ostream& os) {
    for (const auto& T : poses) {
      const auto v = toRowMajor3x4(T);
      for (std::size_t k = 0; k < 12; ++k) os << (k ? " " : "") << formatExact(v[k]);
      os << '\n';
    }
  });
}

std::vector<Isometry3d> posesOf(const Trajectory& trajectory) {
  std::vector<Isometry3d> out;
  out.reserve(trajectory.size());
  for (const auto& p : trajectory) out.push_back(p.T);
  return out;
}

std::vector<double> timestampsOf(const Trajectory& trajectory) {
  std::vector<double> out;
  out.reserve(trajectory.size());
  for (const auto& p : trajectory) out.push_back(p.t);
  return out;
}

Trajectory stampPoses(const std::vector<Isometry3d>& poses, const std::vector<double>& times) {
  OBM_ASSERT(poses.size() == times.size(), std::to_string(poses.size()) + " poses but " +
                                               std::to_string(times.size()) + " time stamps");
  Trajectory out(poses.size());
  for (std::size_t i = 0; i < poses.size(); ++i) out[i] = {times[i], poses[i]};
  return out;
}

std::vector<TimestampMatch> associateTimestamps(const std::vector<double>& first,
                                                const std::vector<double>& second,
                                                double max_difference, double offset) {
  const auto all_finite = [](const std::vector<double>& v) {
    return std::all_of(v.begin(), v.end(), [](double x) { return std::isfinite(x); });
  };
  OBM_ASSERT(all_finite(first) && all_finite(second), "time stamps must be finite");
  OBM_ASSERT(std::isfinite(offset) && max_difference >= 0.0,
             "offset must be finite and max_difference non-negative");
  // associate.py builds every candidate (a, b) with |a − (b + offset)| < max_difference, sorts them
  // by (difference, a, b) and accepts a candidate when neither a nor b is taken yet. The second
  // sequence is searched through a sorted index so only the candidates themselves are visited.
  std::vector<std::size_t> order(second.size());
  std::iota(order.begin(), order.end(), std::size_t{0});
  std::sort(order.begin(), order.end(), [&](std::size_t x, std::size_t y) {
    return std::tie(second[x], x) < std::tie(second[y], y);
  });
  struct Candidate {
    double diff;
    std::size_t a, b;
  };
  std::vector<Candidate> cand;
  for (std::size_t a = 0; a < first.size(); ++a) {
    const double lo = first[a] - offset - max_difference;
    auto it = std::lower_bound(order.begin(), order.end(), lo,
                               [&](std::size_t idx, double v) { return second[idx] < v; });
    for (; it != order.end(); ++it) {
      const double d = std::abs(first[a] - (second[*it] + offset));
      if (d < max_difference) {
        cand.push_back({d, a, *it});
      } else if (second[*it] + offset > first[a]) {
        break;  // beyond the window on the far side
      }
    }
  }
  std::sort(cand.begin(), cand.end(), [&](const Candidate& x, const Candidate& y) {
    return std::make_tuple(x.diff, first[x.a], second[x.b], x.a, x.b) <
           std::make_tuple(y.diff, first[y.a], second[y.b], y.a, y.b);
  });
  std::vector<char> used_a(first.size(), 0), used_b(second.size(), 0);
  std::vector<TimestampMatch> out;
  for (const auto& c : cand) {
    if (used_a[c.a] || used_b[c.b]) continue;
    used_a[c.a] = used_b[c.b] = 1;
    out.push_back({c.a, c.b, c.diff});
  }
  std::sort(out.begin(), out.end(), [&](const TimestampMatch& x, const TimestampMatch& y) {
    return std::tie(first[x.first], x.first) < std::tie(first[y.first], y.first);
  });
  return out;
}

std::vector<TimestampMatch> associate(const Trajectory& first, const Trajectory& second,
                                      double max_difference, double offset) {
  return associateTimestamps(timestampsOf(first), timestampsOf(second), max_difference, offset);
}

}  // namespace obm::io
