#pragma once
// The benchmark drive of the LiDAR tests (obm-sim urban_revisits, seed 5: a city no training run
// used), simulated in the test (no file).
#include <cstddef>
#include <cstdint>
#include <memory>

#include "obm/core/point_cloud.hpp"
#include "obm/sim/lidar.hpp"
#include "obm/sim/scene.hpp"
#include "obm/sim/simulator.hpp"

namespace obm::test {

struct SeedFiveDrive {
  sim::SequenceSimulator simulator;
  std::unique_ptr<sim::RaycastScene> scene;
  std::unique_ptr<sim::LidarSimulator> lidar;
  SeedFiveDrive() : simulator(config()) {
    simulator.prepare();
    scene = std::make_unique<sim::RaycastScene>(simulator.scene().mesh);
    lidar = std::make_unique<sim::LidarSimulator>(simulator.config().sensor.lidar);
  }
  static sim::SimConfig config() {
    sim::SimCommandLine cl;
    cl.preset = "urban_revisits";
    cl.seed = 5;
    return sim::resolveConfig(cl);
  }
  const sim::Trajectory& traj() const { return simulator.trajectory(); }
  /// The raw sweep at pose k (sensor frame), its noise seeded by noise_seed + k.
  PointCloud rawSweep(std::size_t k, std::uint64_t noise_seed) const {
    return lidar->simulate(*scene, traj().poses.at(k), traj().stamps.at(k), noise_seed + k).cloud;
  }
};

}  // namespace obm::test
