// The procedural drive through the urban grid.
#include <algorithm>
#include <cmath>

#include "obm/core/errors.hpp"
#include "obm/core/se3.hpp"
#include "obm/sim/random.hpp"
#include "obm/sim/scenes.hpp"

namespace obm::sim {

using V2 = Eigen::Vector2d;
using V3 = Eigen::Vector3d;

DriveParams DriveParams::load(const ConfigNode& n) {
  DriveParams p;
  n.checkKeys({"type", "route", "speed", "turn_speed", "acceleration", "lane_offset", "turn_radius",
               "sensor_height", "vibration_deg"});
  if (n.has("route")) {
    const auto r = n.required<std::vector<std::vector<int>>>("route");
    for (std::size_t k = 0; k < r.size(); ++k) {
      if (r[k].size() != 2)
        throw ConfigError(n.where("route") + ": entry " + std::to_string(k) +
                          " must be [i, j] (an intersection of the grid)");
      p.route.push_back({r[k][0], r[k][1]});
    }
  }
  n.get("speed", p.speed);
  n.get("turn_speed", p.turn_speed);
  n.get("acceleration", p.acceleration);
  n.get("lane_offset", p.lane_offset);
  n.get("turn_radius", p.turn_radius);
  n.get("sensor_height", p.sensor_height);
  n.get("vibration_deg", p.vibration_deg);
  if (!(p.speed > 0.0)) throw ConfigError(n.where("speed") + ": must be positive");
  if (!(p.turn_speed > 0.0)) throw ConfigError(n.where("turn_speed") + ": must be positive");
  if (!(p.acceleration > 0.0)) throw ConfigError(n.where("acceleration") + ": must be positive");
  if (!(p.turn_radius > 0.5)) throw ConfigError(n.where("turn_radius") + ": must be > 0.5 m");
  return p;
}

namespace {
struct PathPoint {
  V2 p;
  bool turning;
};

V2 rightNormal(const V2& d) {
  return V2(d.y(), -d.x());
}
double cross2(const V2& a, const V2& b) {
  return a.x() * b.y() - a.y() * b.x();
}

// Offsets a polyline to the right by `lane` and rounds each corner with radius r, sampled
// every `step`. `closed`: the polyline is a loop (first point == last point after the cycle).
std::vector<PathPoint> roundedOffsetPath(const std::vector<V2>& pts, bool closed, double lane,
                                         double r, double step) {
  const std::size_t n = pts.size();
  std::vector<V2> dirs;
  for (std::size_t i = 0; i + 1 < n; ++i) dirs.push_back((pts[i + 1] - pts[i]).normalized());
  // Offset corner points: intersection of consecutive offset lines.
  std::vector<V2> q(n);
  for (std::size_t i = 0; i < n; ++i) {
    V2 din, dout;
    if (i == 0) {
      dout = dirs.front();
      din = closed ? dirs.back() : dout;
    } else if (i == n - 1) {
      din = dirs.back();
      dout = closed ? dirs.front() : din;
    } else {
      din = dirs[i - 1];
      dout = dirs[i];
    }
    const V2 r1 = rightNormal(din), r2 = rightNormal(dout);
    q[i] = pts[i] + lane * (r1 + r2) / (1.0 + r1.dot(r2));
  }
  std::vector<PathPoint> out;
  auto line = [&](const V2& a, const V2& b) {
    const double L = (b - a).norm();
    const int k = std::max(1, static_cast<int>(std::ceil(L / step)));
    for (int s = 0; s < k; ++s) out.push_back({a + (b - a) * (static_cast<double>(s) / k), false});
  };
  V2 cur = q.front();
  for (std::size_t i = 1; i + 1 < n; ++i) {
    const V2 a = dirs[i - 1], b = dirs[i];
    const double phi = std::acos(std::clamp(a.dot(b), -1.0, 1.0));
    if (phi < 1e-6) continue;
    const double lin = (q[i] - q[i - 1]).norm(), lout = (q[i + 1] - q[i]).norm();
    const double rr = std::min(r, 0.45 * std::min(lin, lout) / std::tan(phi / 2));
    const double dt = rr * std::tan(phi / 2);
    const V2 t1 = q[i] - a * dt, t2 = q[i] + b * dt;
    line(cur, t1);
    const double sgn = cross2(a, b) > 0 ? 1.0 : -1.0;  // left turn: centre on the left
    const V2 c = t1 + sgn * rr * V2(-a.y(), a.x());
    const double a0 = std::atan2(t1.y() - c.y(), t1.x() - c.x());
    const int k = std::max(2, static_cast<int>(std::ceil(rr * phi / step)));
    for (int s = 0; s < k; ++s) {
      const double ang = a0 + sgn * phi * s / k;
      out.push_back({c + rr * V2(std::cos(ang), std::sin(ang)), true});
    }
    cur = t2;
  }
  line(cur, q.back());
  out.push_back({q.back(), false});
  return out;
}
}  // namespace

Trajectory generateDrive(const UrbanSceneParams& S, const GeneratedScene& G, const DriveParams& P) {
  std::vector<std::array<int, 2>> route = P.route;
  if (route.empty()) {
    const int nx = S.blocks_x, ny = S.blocks_y, mid = std::max(1, nx / 2);
    route = {{0, 0}, {nx, 0}, {nx, ny}, {0, ny}, {0, 0}, {mid, 0}, {mid, ny}, {0, ny}, {0, 0}};
  }
  // Validate: inside the drivable grid, straight moves along streets, no U-turns.
  std::vector<V2> nodes;
  for (std::size_t k = 0; k < route.size(); ++k) {
    const auto [i, j] = route[k];
    if (i < 0 || i > S.blocks_x || j < 0 || j > S.blocks_y)
      throw ConfigError("trajectory.route: entry " + std::to_string(k) + " [" + std::to_string(i) +
                        ", " + std::to_string(j) + "] leaves the grid of " +
                        std::to_string(S.blocks_x) + "×" + std::to_string(S.blocks_y) + " blocks");
    if (k > 0 && route[k - 1][0] != i && route[k - 1][1] != j)
      throw ConfigError("trajectory.route: entry " + std::to_string(k) +
                        " is not on the same street as the previous one");
    const V2 p(i * S.block_length_x, j * S.block_length_y);
    if (nodes.empty() || (p - nodes.back()).norm() > 1e-9) nodes.push_back(p);
  }
  if (nodes.size() < 2)
    throw ConfigError("trajectory.route: needs at least two distinct intersections");
  // Drop intermediate collinear nodes; reject reversals.
  std::vector<V2> pts = {nodes.front()};
  for (std::size_t k = 1; k + 1 < nodes.size(); ++k) {
    const V2 a = (nodes[k] - pts.back()).normalized(), b = (nodes[k + 1] - nodes[k]).normalized();
    if (a.dot(b) < -0.5)
      throw ConfigError("trajectory.route: the route turns back on itself at entry " +
                        std::to_string(k));
    if (a.dot(b) < 1.0 - 1e-9) pts.push_back(nodes[k]);
  }
  pts.push_back(nodes.back());
  const bool closed = (pts.front() - pts.back()).norm() < 1e-6 && pts.size() >= 4;
  if (closed) {
    // Start and end halfway along the first street so that the loop closes smoothly.
    const V2 start = 0.5 * (pts[0] + pts[1]);
    std::vector<V2> cyc = {start};
    cyc.insert(cyc.end(), pts.begin() + 1, pts.end());
    cyc.push_back(start);
    const V2 a = (cyc[cyc.size() - 2] - cyc[cyc.size() - 3]).normalized();
    const V2 b = (cyc[1] - cyc[0]).normalized();
    if (a.dot(b) < -0.5) throw ConfigError("trajectory.route: the loop turns back at its start");
    pts = cyc;
  }

  const double ds = 0.25;
  const auto path = roundedOffsetPath(pts, false, P.lane_offset, P.turn_radius, ds);
  const std::size_t n = path.size();
  // Speed profile with acceleration limits (forward and backward passes).
  std::vector<double> v(n), s(n, 0.0);
  for (std::size_t i = 1; i < n; ++i) s[i] = s[i - 1] + (path[i].p - path[i - 1].p).norm();
  for (std::size_t i = 0; i < n; ++i) v[i] = path[i].turning ? P.turn_speed : P.speed;
  for (std::size_t i = 1; i < n; ++i)
    v[i] = std::min(v[i], std::sqrt(v[i - 1] * v[i - 1] + 2 * P.acceleration * (s[i] - s[i - 1])));
  for (std::size_t i = n - 1; i-- > 0;)
    v[i] = std::min(v[i], std::sqrt(v[i + 1] * v[i + 1] + 2 * P.acceleration * (s[i + 1] - s[i])));
  std::vector<double> t(n, 0.0);
  for (std::size_t i = 1; i < n; ++i)
    t[i] = t[i - 1] + (s[i] - s[i - 1]) / std::max(0.1, 0.5 * (v[i] + v[i - 1]));

  // Stretch the timing by less than one period so the last sample lands on the end point.
  const double dt = 1.0 / P.rate_hz;
  const double stretch = std::ceil(t.back() / dt - 1e-9) * dt / t.back();
  for (double& x : t) x *= stretch;

  Rng rng(hashSeed(P.seed, 0xd21e));
  double ph[6];
  for (double& x : ph) x = rng.uniform(0, 2 * M_PI);
  const double vib = P.vibration_deg * kDegToRad;

  Trajectory traj;
  traj.source = "procedural drive";
  std::size_t i = 0;
  const auto frames = static_cast<std::size_t>(std::llround(t.back() / dt)) + 1;
  for (std::size_t f = 0; f < frames; ++f) {
    const double tk = static_cast<double>(f) * dt;
    while (i + 1 < n && t[i + 1] < tk) ++i;
    const std::size_t j = std::min(i + 1, n - 1);
    const double a = t[j] > t[i] ? std::clamp((tk - t[i]) / (t[j] - t[i]), 0.0, 1.0) : 0.0;
    const V2 p = (1 - a) * path[i].p + a * path[j].p;
    // Heading from a short look-ahead / look-behind chord.
    const std::size_t ia = i >= 4 ? i - 4 : 0, ib = std::min(n - 1, j + 4);
    const V2 d = (path[ib].p - path[ia].p).normalized();
    const V2 l(-d.y(), d.x());
    const double yaw = std::atan2(d.y(), d.x());
    // Body attitude from the ground under the wheels (wheelbase 2.7 m, track 1.6 m).
    const auto h = [&](const V2& q) { return G.ground.at(q.x(), q.y()); };
    const double pitch = -std::atan2(h(p + 1.35 * d) - h(p - 1.35 * d), 2.7);
    const double roll = std::atan2(h(p + 0.8 * l) - h(p - 0.8 * l), 1.6);
    const double dp =
        vib * (std::sin(2 * M_PI * 1.3 * tk + ph[0]) + 0.5 * std::sin(2 * M_PI * 3.1 * tk + ph[1]));
    const double dr =
        vib * (std::sin(2 * M_PI * 1.1 * tk + ph[2]) + 0.5 * std::sin(2 * M_PI * 2.7 * tk + ph[3]));
    const double dz = 0.01 * std::sin(2 * M_PI * 1.7 * tk + ph[4]);
    const Eigen::Matrix3d R = fromEulerZYX(V3(yaw, pitch + dp, roll + dr));
    const V3 ground_pt(p.x(), p.y(), h(p));
    traj.push_back(tk, makeIsometry(R, ground_pt + R * V3(0, 0, P.sensor_height + dz)));
  }
  return traj;
}

}  // namespace obm::sim
