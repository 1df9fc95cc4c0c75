#pragma once
/// \file lidar.hpp
/// A spinning multi-beam LiDAR (Velodyne HDL-64E, VLP-16 or a custom ring layout) simulated by
/// casting one ray per (ring, azimuth column) into a RaycastScene.
///
/// Sensor frame: x forward, y left, z up (the KITTI velodyne frame). The head spins clockwise seen
/// from above, starting behind the vehicle (azimuth +180°) so that it faces forward (azimuth 0)
/// at the middle of the sweep, which is the sweep's time stamp — as in KITTI, whose cameras are
/// triggered when the LiDAR faces forward.
#include <Eigen/Geometry>
#include <cstdint>
#include <functional>
#include <string>
#include <vector>

#include "obm/config/config_node.hpp"
#include "obm/core/point_cloud.hpp"
#include "obm/sim/scene.hpp"

namespace obm::sim {

/// Parameters of a spinning LiDAR. Defaults: Velodyne HDL-64E at 10 Hz.
struct LidarParams {
  /// Ring layout: "hdl64" (64 rings, +2.0° … −24.9°: 32 upper rings 1/3° apart, 32 lower rings
  /// evenly from −8.83° to −24.9°), "vlp16" (16 rings, −15° … +15° every 2°), "uniform"
  /// (`rings` evenly from `max_elevation_deg` to `min_elevation_deg`) or "custom"
  /// (`elevations_deg`).
  std::string layout = "hdl64";
  std::vector<double> elevations_deg;  ///< [deg] custom layout, one per ring
  int rings = 64;                      ///< uniform layout
  double max_elevation_deg = 2.0;      ///< [deg] uniform layout, first ring
  double min_elevation_deg = -24.9;    ///< [deg] uniform layout, last ring
  double azimuth_step_deg = 0.17;  ///< [deg] horizontal resolution (HDL-64E at 10 Hz ≈ 0.17°)
  double rate_hz = 10.0;           ///< [Hz] rotation rate = sweeps per second
  double min_range = 0.9;          ///< [m] closer returns are discarded
  double max_range = 120.0;        ///< [m] farthest possible return

  // Noise and drop-outs (all disabled by `noise = false`).
  bool noise = true;                  ///< master switch for everything random below
  double range_noise_sigma = 0.02;    ///< [m] Gaussian range noise (HDL-64E: < 2 cm, 1σ)
  double dropout_probability = 0.01;  ///< random loss of a return
  double grazing_start_deg = 85.0;    ///< [deg] incidence where grazing loss starts
  double grazing_full_deg = 89.5;     ///< [deg] incidence where every return is lost
  /// [m] range at which a 10 %-reflective surface at normal incidence is still detected
  /// (HDL-64E datasheet: 50 m for pavement); a return is kept when ρ·(0.3 + 0.7·cosθ)·(R₁₀/r)²
  /// ≥ 0.1 — surfaces are not purely Lambertian, so grazing pavement is still seen to ~40 m, as
  /// in KITTI's scans. 0 disables.
  double range_at_10pct = 50.0;
  /// Intensity in [0, 1]: ρ·(0.5 + 0.5·cosθ)·1.8·exp(−r / 40 m) plus Gaussian noise — near
  /// asphalt ≈ 0.2, far asphalt ≈ 0.1, as in KITTI's reflectance channel.
  double intensity_noise_sigma = 0.02;
  bool material_effects = true;  ///< glass/car windows drop returns, foliage is partly penetrated

  /// Points are measured from the pose at each column's firing time (raw, like KITTI's .bin
  /// files) instead of all from the sweep's pose.
  bool motion_distortion = false;

  int threads = 0;  ///< ray-casting threads (0 = all cores)

  /// Reads the keys above from a `sensor:` map (angles in degrees). Throws ConfigError naming the
  /// key for unknown keys, an unknown layout or a configuration with zero rays.
  static LidarParams load(const ConfigNode& node);
  /// The same checks on the values in memory (throws ConfigError naming the offending key).
  void validate(const std::string& where = "lidar") const;

  /// Ring elevations [rad] from the first (highest) to the last ring.
  std::vector<double> ringElevations() const;
  /// Azimuth columns per sweep (round(360° / azimuth_step_deg)).
  std::size_t columns() const;
  /// Rays per sweep = rings × columns.
  std::size_t raysPerSweep() const;
  /// Sweep duration [s].
  double sweepPeriod() const { return 1.0 / rate_hz; }
};

/// One simulated sweep.
struct LidarSweep {
  /// Points [m] in the sensor frame, intensity in [0, 1]; frame_id "lidar", timestamp = sweep
  /// time. With motion distortion, each point is in the sensor frame at its own firing time.
  PointCloud cloud;
  std::vector<std::uint16_t> ring;    ///< ring index per point (0 = highest)
  std::vector<std::uint16_t> column;  ///< azimuth column per point (0 = first fired, behind)
  std::vector<float> time_offset;     ///< [s] firing time minus the sweep's time stamp, per point
  std::size_t rays = 0;               ///< rays cast (including misses and drop-outs)
};

/// Pose of the sensor in the world at a time, T_world_sensor(t).
using PoseAtTime = std::function<Eigen::Isometry3d(double)>;

class LidarSimulator {
 public:
  /// Validates the parameters (throws ConfigError) and builds the per-ring and per-column
  /// direction tables once.
  explicit LidarSimulator(LidarParams params);

  const LidarParams& params() const { return params_; }

  /// Simulates the sweep stamped `t` (the middle of the rotation). `pose(t')` gives
  /// T_world_sensor; without motion distortion only pose(t) is used. `seed` makes the noise
  /// reproducible: the same seed gives the same sweep for any thread count.
  LidarSweep simulate(const RaycastScene& scene, const PoseAtTime& pose, double t,
                      std::uint64_t seed) const;
  /// Static sensor at `T_world_sensor`.
  LidarSweep simulate(const RaycastScene& scene, const Eigen::Isometry3d& T_world_sensor, double t,
                      std::uint64_t seed) const;

  /// Unit direction of (ring, column) in the sensor frame.
  Eigen::Vector3f direction(std::size_t ring, std::size_t column) const;
  /// Azimuth [rad] of a column (counter-clockwise from +x).
  double azimuth(std::size_t column) const;
  /// Firing time of a column relative to the sweep's time stamp [s].
  double columnTimeOffset(std::size_t column) const;

 private:
  LidarParams params_;
  std::vector<float> cos_el_, sin_el_;  // per ring
  std::vector<float> cos_az_, sin_az_;  // per column
};

}  // namespace obm::sim
