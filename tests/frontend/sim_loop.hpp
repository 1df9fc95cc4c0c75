#pragma once
// A short simulated drive around one block of a small procedural city (libs/sim), generated in
// memory once per test program: LiDAR sweeps in the sensor frame and the ground-truth poses
// T_world_sensor with the first sweep's frame as the world (as the front-end estimates them).
#include <algorithm>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "obm/config/config_node.hpp"
#include "obm/core/point_cloud.hpp"
#include "obm/core/se3.hpp"
#include "obm/sim/lidar.hpp"
#include "obm/sim/scene.hpp"
#include "obm/sim/simulator.hpp"

namespace obm::test {

struct SimLoop {
  std::vector<PointCloud> sweeps;  ///< sensor frame, timestamp set
  std::vector<Isometry3d> truth;   ///< T_world_sensor, truth[0] = I
};

/// Simulates the sequence of the obm-sim configuration `yaml` in memory: its first `max_frames`
/// sweeps (0 = all), sweep i with noise seed `noise_seed + i`, stamps and poses relative to the
/// first sweep.
inline SimLoop simulateDrive(const char* yaml, const std::string& origin, std::size_t max_frames,
                             std::uint64_t noise_seed) {
  sim::SimConfig cfg = sim::SimConfig::load(ConfigNode::fromString(yaml, origin));
  sim::SequenceSimulator simulator(cfg);
  simulator.prepare();
  const sim::Trajectory& traj = simulator.trajectory();
  sim::RaycastScene scene(simulator.scene().mesh);
  sim::LidarSimulator lidar(cfg.sensor.lidar);
  SimLoop out;
  const Isometry3d T_0_world = traj.poses.front().inverse();
  const std::size_t n = max_frames > 0 ? std::min(max_frames, traj.size()) : traj.size();
  for (std::size_t i = 0; i < n; ++i) {
    sim::LidarSweep s = lidar.simulate(scene, traj.poses[i], traj.stamps[i], noise_seed + i);
    s.cloud.timestamp = traj.stamps[i] - traj.stamps.front();
    out.sweeps.push_back(std::move(s.cloud));
    out.truth.push_back(T_0_world * traj.poses[i]);
  }
  return out;
}

/// The drive of simLoop() along `route` (block corners in units of the block, as obm-sim's
/// `trajectory.route`).
inline SimLoop simulateBlockDrive(const std::string& route) {
  const std::string yaml = R"(
name: frontend_test_loop
seed: 7
frames: 0
scene:
  type: urban_grid
  blocks_x: 1
  blocks_y: 1
  block_length_x: 60.0
  block_length_y: 55.0
  building_depth_max: 12.0
  margin: 10.0
  terrain_resolution: 1.5
  car_probability: 0.6
sensor:
  type: lidar
  layout: hdl64
  azimuth_step_deg: 0.8
  rate_hz: 4.0
  max_range: 80.0
  range_noise_sigma: 0.02
trajectory:
  type: drive
  route: )" + route + R"(
  speed: 10.0
  turn_speed: 6.0
output:
  format: kitti
)";
  return simulateDrive(yaml.c_str(), "frontend_test_loop", 0, 100);
}

/// One loop around a 60 m × 55 m block at 10 m/s, sweeps at 4 Hz (2.5 m apart), a 64-ring LiDAR
/// with 0.8° columns and 2 cm range noise: ~126 sweeps of ~20k points.
inline const SimLoop& simLoop() {
  static const SimLoop loop = simulateBlockDrive("[[0, 0], [1, 0], [1, 1], [0, 1], [0, 0]]");
  return loop;
}

/// Translation [m] and rotation [deg] of A⁻¹·B.
inline std::pair<double, double> poseError(const Isometry3d& A, const Isometry3d& B) {
  const Isometry3d d = A.inverse() * B;
  return {d.translation().norm(), rotationAngle(d.linear()) * kRadToDeg};
}

}  // namespace obm::test
