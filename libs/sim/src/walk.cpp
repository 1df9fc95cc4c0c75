// The procedural hand-held walk through the indoor floor.
#include <algorithm>
#include <cmath>

#include "indoor_layout.hpp"
#include "obm/core/errors.hpp"
#include "obm/core/se3.hpp"
#include "obm/sim/random.hpp"
#include "obm/sim/scenes.hpp"

namespace obm::sim {

using V2 = Eigen::Vector2d;
using V3 = Eigen::Vector3d;

WalkParams WalkParams::load(const ConfigNode& n) {
  WalkParams p;
  n.checkKeys({"type", "speed", "camera_height", "pitch_deg", "sway_deg", "bob"});
  n.get("speed", p.speed);
  n.get("camera_height", p.camera_height);
  n.get("pitch_deg", p.pitch_deg);
  n.get("sway_deg", p.sway_deg);
  n.get("bob", p.bob);
  if (!(p.speed > 0.0) || p.speed > 3.0)
    throw ConfigError(n.where("speed") + ": must be in (0, 3] m/s");
  if (!(p.camera_height > 0.3)) throw ConfigError(n.where("camera_height") + ": must be > 0.3 m");
  return p;
}

/// T_world_camera (optical frame) looking along heading `yaw` [rad], tilted by `pitch` (positive
/// up) and rolled by `roll`.
static Eigen::Matrix3d opticalRotation(double yaw, double pitch, double roll) {
  const V3 fwd(std::cos(pitch) * std::cos(yaw), std::cos(pitch) * std::sin(yaw), std::sin(pitch));
  const V3 right0(std::sin(yaw), -std::cos(yaw), 0.0);
  const V3 down0 = fwd.cross(right0);
  const V3 right = std::cos(roll) * right0 + std::sin(roll) * down0;
  const V3 down = fwd.cross(right);
  Eigen::Matrix3d R;
  R.col(0) = right;
  R.col(1) = down;
  R.col(2) = fwd;
  return R;
}

Trajectory generateWalk(const IndoorSceneParams& S, const GeneratedScene& G, const WalkParams& P) {
  const detail::IndoorLayout L = detail::indoorLayout(S);
  const auto& A = L.rooms[static_cast<std::size_t>(L.start_room)];
  const auto& B = L.rooms[static_cast<std::size_t>(L.goal_room)];
  // Waypoints: a small loop in room A, out through its door, along the corridor, into room B,
  // a loop there, back along the corridor and into room A to the start.
  std::vector<V2> wp;
  auto loopIn = [&](const detail::IndoorRoom& r, double phase) {
    const V2 c = r.freeCentre();
    for (int k = 0; k <= 8; ++k) {
      const double a = phase + 2 * M_PI * k / 8.0;
      wp.push_back(c + 0.55 * V2(std::cos(a), std::sin(a)));
    }
  };
  auto door = [&](const detail::IndoorRoom& r, bool entering) {
    const V2 in(r.door_x, r.y_wall + r.side * 1.0), out(r.door_x, 0.0);
    if (entering) {
      wp.push_back(out);
      wp.push_back(V2(r.door_x, r.y_wall));
      wp.push_back(in);
    } else {
      wp.push_back(in);
      wp.push_back(V2(r.door_x, r.y_wall));
      wp.push_back(out);
    }
  };
  const double phaseA = std::atan2(A.side * 1.0, 0.0) + M_PI;  // start on the door side
  loopIn(A, phaseA);
  door(A, false);
  door(B, true);
  loopIn(B, std::atan2(B.side * 1.0, 0.0) + M_PI);
  door(B, false);
  door(A, true);
  wp.push_back(wp.front());
  // Chaikin corner cutting (4 rounds) smooths the polyline into a walkable curve; the end points
  // stay fixed so the walk closes.
  for (int it = 0; it < 4; ++it) {
    std::vector<V2> s = {wp.front()};
    for (std::size_t i = 0; i + 1 < wp.size(); ++i) {
      s.push_back(0.75 * wp[i] + 0.25 * wp[i + 1]);
      s.push_back(0.25 * wp[i] + 0.75 * wp[i + 1]);
    }
    s.push_back(wp.back());
    wp.swap(s);
  }
  std::vector<double> cum(1, 0.0);
  for (std::size_t i = 1; i < wp.size(); ++i)
    cum.push_back(cum.back() + (wp[i] - wp[i - 1]).norm());
  const double total = cum.back();
  const double duration = total / P.speed;
  const double dt = 1.0 / P.rate_hz;
  const auto n = static_cast<std::size_t>(std::floor(duration / dt)) + 1;

  // Positions along the curve at constant speed; headings from a 0.5 m look-ahead chord,
  // low-pass filtered forwards and backwards so the camera turns smoothly.
  std::vector<V2> pos(n);
  std::vector<double> yaw(n);
  auto at = [&](double s) {
    s = std::clamp(s, 0.0, total);
    const auto it = std::upper_bound(cum.begin(), cum.end(), s);
    const std::size_t k =
        std::clamp<std::size_t>(static_cast<std::size_t>(it - cum.begin()), 1, wp.size() - 1);
    const double seg = cum[k] - cum[k - 1];
    const double a = seg > 0 ? (s - cum[k - 1]) / seg : 0.0;
    return V2((1 - a) * wp[k - 1] + a * wp[k]);
  };
  for (std::size_t k = 0; k < n; ++k) {
    const double s = std::min(total, P.speed * k * dt);
    pos[k] = at(s);
    V2 d = at(std::min(total, s + 0.5)) - at(std::max(0.0, s - 0.5));
    if (d.norm() < 1e-9) d = V2(1, 0);
    yaw[k] = std::atan2(d.y(), d.x());
    if (k > 0) yaw[k] = yaw[k - 1] + wrapAngle(yaw[k] - yaw[k - 1]);  // unwrap
  }
  const double alpha = dt / (0.6 + dt);
  for (std::size_t k = 1; k < n; ++k) yaw[k] = yaw[k - 1] + alpha * (yaw[k] - yaw[k - 1]);
  for (std::size_t k = n - 1; k-- > 0;) yaw[k] = yaw[k + 1] + alpha * (yaw[k] - yaw[k + 1]);

  Rng rng(hashSeed(P.seed, 0x3a1c));
  double ph[6];
  for (double& x : ph) x = rng.uniform(0, 2 * M_PI);
  const double floor_z = G.ground.at(pos.front().x(), pos.front().y());
  Trajectory traj;
  traj.source = "procedural walk";
  for (std::size_t k = 0; k < n; ++k) {
    const double t = k * dt;
    // Looking around slowly, a step rhythm of ~1.8 Hz in height, and a little hand tremor.
    const double sway = P.sway_deg * kDegToRad * std::sin(2 * M_PI * t / 7.0 + ph[0]);
    const double pitch = P.pitch_deg * kDegToRad +
                         0.25 * P.sway_deg * kDegToRad * std::sin(2 * M_PI * t / 5.3 + ph[1]) +
                         0.3 * kDegToRad * std::sin(2 * M_PI * 1.8 * t + ph[2]);
    const double roll = 1.5 * kDegToRad * std::sin(2 * M_PI * t / 4.1 + ph[3]);
    const double z = floor_z + P.camera_height + P.bob * std::sin(2 * M_PI * 1.8 * t + ph[4]);
    traj.push_back(t, makeIsometry(opticalRotation(yaw[k] + sway, pitch, roll),
                                   V3(pos[k].x(), pos[k].y(), z)));
  }
  return traj;
}

}  // namespace obm::sim
