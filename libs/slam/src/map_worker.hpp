#pragma once
// Private: integrates keyframe clouds into the OctoMap in a worker thread while the front-end
// runs, keeps them (voxelised) and, at the end, rebuilds the map at the final poses when the
// pose-graph optimisation moved a keyframe by more than a tolerance.
#include <condition_variable>
#include <cstddef>
#include <deque>
#include <map>
#include <mutex>
#include <thread>
#include <vector>

#include "obm/core/point_cloud.hpp"
#include "obm/core/se3.hpp"
#include "obm/mapping/occupancy_map.hpp"

namespace obm::slam::detail {

class MapWorker {
 public:
  /// `cloud_voxel` [m]: stored clouds are voxelised at this size in the sensor frame (0 = off).
  /// `max_queue`: push() blocks while this many clouds wait (bounds the memory).
  MapWorker(const mapping::MappingParams& params, double cloud_voxel, std::size_t max_queue = 8);
  ~MapWorker();
  MapWorker(const MapWorker&) = delete;
  MapWorker& operator=(const MapWorker&) = delete;

  /// Queues keyframe `id`'s cloud (sensor frame) for insertion at T_map_sensor.
  void push(std::size_t id, PointCloud cloud_sensor, const Isometry3d& T_map_sensor);

  /// Waits for the queue to drain and stops the thread. Then, when any keyframe's final pose
  /// (`final_poses`, by id) differs from the pose it was inserted at by more than the tolerances,
  /// clears the map and integrates every stored cloud at its final pose. Returns true when it
  /// rebuilt. Rethrows an exception the worker caught.
  bool finish(const std::map<std::size_t, Isometry3d>& final_poses, double max_translation,
              double max_rotation);
  /// Largest translation [m] / rotation [rad] between a keyframe's insertion pose and its final
  /// pose (after finish()).
  double maxShift() const { return max_shift_; }
  double maxShiftRotation() const { return max_shift_rot_; }

  mapping::OccupancyMap& map() { return map_; }
  /// [ms] busy time of the worker (insertions) plus the rebuild.
  double busyMs() const { return busy_ms_; }
  std::size_t inserted() const { return clouds_.size(); }

 private:
  struct Job {
    std::size_t id;
    PointCloud cloud;
    Isometry3d T;
  };
  void loop();

  mapping::OccupancyMap map_;
  double voxel_;
  std::size_t max_queue_;
  std::mutex mutex_;
  std::condition_variable cv_;
  std::deque<Job> queue_;
  bool stop_ = false;
  std::exception_ptr error_;
  std::thread thread_;
  // Written by the worker only; read by finish() after join.
  std::vector<std::size_t> ids_;
  std::vector<PointCloud> clouds_;
  std::vector<Isometry3d> inserted_at_;
  double busy_ms_ = 0.0;
  double max_shift_ = 0.0, max_shift_rot_ = 0.0;
};

}  // namespace obm::slam::detail
