#include "map_worker.hpp"

#include "obm/core/cloud_ops.hpp"
#include "obm/core/timer.hpp"

namespace obm::slam::detail {

MapWorker::MapWorker(const mapping::MappingParams& params, double cloud_voxel,
                     std::size_t max_queue)
    : map_(params), voxel_(cloud_voxel), max_queue_(std::max<std::size_t>(1, max_queue)) {
  thread_ = std::thread([this] { loop(); });
}

MapWorker::~MapWorker() {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    stop_ = true;
  }
  cv_.notify_all();
  if (thread_.joinable()) thread_.join();
}

void MapWorker::push(std::size_t id, PointCloud cloud_sensor, const Isometry3d& T_map_sensor) {
  std::unique_lock<std::mutex> lock(mutex_);
  cv_.wait(lock, [&] { return queue_.size() < max_queue_ || stop_; });
  queue_.push_back(Job{id, std::move(cloud_sensor), T_map_sensor});
  lock.unlock();
  cv_.notify_all();
}

void MapWorker::loop() {
  while (true) {
    Job job;
    {
      std::unique_lock<std::mutex> lock(mutex_);
      cv_.wait(lock, [&] { return !queue_.empty() || stop_; });
      if (queue_.empty()) return;  // stop_ and drained
      job = std::move(queue_.front());
      queue_.pop_front();
    }
    cv_.notify_all();
    if (error_) continue;  // keep draining so push() never blocks forever
    try {
      Timer t;
      PointCloud c = voxel_ > 0.0 ? voxelDownsample(job.cloud, voxel_) : std::move(job.cloud);
      c.intensity.clear();
      map_.insert(c, job.T);
      ids_.push_back(job.id);
      clouds_.push_back(std::move(c));
      inserted_at_.push_back(job.T);
      busy_ms_ += t.ms();
    } catch (...) {
      error_ = std::current_exception();
    }
  }
}

bool MapWorker::finish(const std::map<std::size_t, Isometry3d>& final_poses, double max_translation,
                       double max_rotation) {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    stop_ = true;
  }
  cv_.notify_all();
  if (thread_.joinable()) thread_.join();
  if (error_) std::rethrow_exception(error_);
  bool rebuild = false;
  std::vector<Isometry3d> poses(ids_.size());
  for (std::size_t i = 0; i < ids_.size(); ++i) {
    const auto it = final_poses.find(ids_[i]);
    poses[i] = it != final_poses.end() ? it->second : inserted_at_[i];
    const Isometry3d d = inserted_at_[i].inverse() * poses[i];
    max_shift_ = std::max(max_shift_, d.translation().norm());
    max_shift_rot_ = std::max(max_shift_rot_, rotationAngle(d.linear()));
    if (d.translation().norm() > max_translation || rotationAngle(d.linear()) > max_rotation)
      rebuild = true;
  }
  if (!rebuild) return false;
  Timer t;
  map_.clear();
  map_.integrate(clouds_, poses);
  busy_ms_ += t.ms();
  return true;
}

}  // namespace obm::slam::detail
