#include "obm/registration/free_space.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <string>

#include "obm/config/config_node.hpp"
#include "obm/core/errors.hpp"

namespace obm::registration {

void FreeSpaceParams::validate() const {
  if (!(azimuth_step_deg > 0.0 && azimuth_step_deg <= 90.0))
    throw ConfigError("free space: azimuth_step_deg must be in (0, 90]");
  if (!(elevation_step_deg > 0.0 && elevation_step_deg <= 90.0))
    throw ConfigError("free space: elevation_step_deg must be in (0, 90]");
  if (!(margin >= 0.0)) throw ConfigError("free space: margin must be >= 0");
  if (!(relative_margin >= 0.0 && relative_margin < 1.0))
    throw ConfigError("free space: relative_margin must be in [0, 1)");
  if (!(min_range >= 0.0)) throw ConfigError("free space: min_range must be >= 0");
}

FreeSpaceParams FreeSpaceParams::load(const ConfigNode& node) {
  FreeSpaceParams p;
  node.checkKeys({"sensor", "azimuth_step_deg", "elevation_step_deg", "margin", "relative_margin",
                  "min_range"});
  if (node.has("sensor")) {
    std::string sensor;
    node.get("sensor", sensor);
    if (sensor == "lidar") {
      p.sensor = FreeSpaceSensor::Lidar;
    } else if (sensor == "camera") {
      p.sensor = FreeSpaceSensor::Camera;
    } else {
      throw ConfigError(node.where("sensor") + ": expected lidar or camera, got '" + sensor + "'");
    }
  }
  node.get("azimuth_step_deg", p.azimuth_step_deg);
  node.get("elevation_step_deg", p.elevation_step_deg);
  node.get("margin", p.margin);
  node.get("relative_margin", p.relative_margin);
  node.get("min_range", p.min_range);
  try {
    p.validate();
  } catch (const ConfigError& e) {
    throw ConfigError(node.where("") + ": " + e.what());
  }
  return p;
}

FreeSpaceParams FreeSpaceParams::depthCamera() {
  FreeSpaceParams p;
  p.sensor = FreeSpaceSensor::Camera;
  p.azimuth_step_deg = 1.0;
  p.elevation_step_deg = 1.0;
  p.margin = 0.05;
  p.relative_margin = 0.05;
  p.min_range = 0.2;
  return p;
}

RangeImage::RangeImage(const std::vector<Vector3f>& points_sensor, const FreeSpaceParams& params)
    : params_(params) {
  params_.validate();
  cols_ = static_cast<int>(std::ceil(360.0 / params_.azimuth_step_deg));
  rows_ = static_cast<int>(std::ceil(180.0 / params_.elevation_step_deg));
  nearest_.assign(static_cast<std::size_t>(cols_) * static_cast<std::size_t>(rows_),
                  std::numeric_limits<float>::infinity());
  float range = 0.0f;
  for (const Vector3f& p : points_sensor) {
    const long c = cell(p, range);
    if (c < 0 || range < params_.min_range) continue;
    float& n = nearest_[static_cast<std::size_t>(c)];
    n = std::min(n, range);
  }
}

long RangeImage::cell(const Vector3f& p_sensor, float& range) const {
  // Forward, left, up: a camera's optical axis becomes the image's middle row and column.
  const Vector3f p = params_.sensor == FreeSpaceSensor::Camera
                         ? Vector3f(p_sensor.z(), -p_sensor.x(), -p_sensor.y())
                         : p_sensor;
  range = p.norm();
  if (!(range > 0.0f) || !std::isfinite(range)) return -1;
  const double az = std::atan2(double(p.y()), double(p.x())) / kDegToRad + 180.0;  // [0, 360]
  const double el =
      std::atan2(double(p.z()), std::hypot(double(p.x()), double(p.y()))) / kDegToRad + 90.0;
  const int c = std::min(cols_ - 1, static_cast<int>(az / params_.azimuth_step_deg));
  const int r = std::min(rows_ - 1, static_cast<int>(el / params_.elevation_step_deg));
  return static_cast<long>(r) * cols_ + c;
}

bool RangeImage::inFreeSpace(const Vector3f& p_sensor) const {
  float range = 0.0f;
  const long c = cell(p_sensor, range);
  if (c < 0 || range < params_.min_range) return false;
  const float n = nearest_[static_cast<std::size_t>(c)];
  if (!std::isfinite(n)) return false;  // no return in this cell: nothing seen, nothing known
  return double(range) < double(n) - params_.margin - params_.relative_margin * double(n);
}

std::size_t RangeImage::countConflicts(const std::vector<Vector3f>& points,
                                       const Isometry3d& T_sensor_B) const {
  const Eigen::Matrix3f R = T_sensor_B.linear().cast<float>();
  const Vector3f t = T_sensor_B.translation().cast<float>();
  std::size_t n = 0;
  for (const Vector3f& p : points) n += inFreeSpace(R * p + t) ? 1 : 0;
  return n;
}

double FreeSpaceConflicts::ratio() const {
  const std::size_t all = num_source + num_target;
  return all == 0 ? 0.0
                  : static_cast<double>(source_in_target + target_in_source) /
                        static_cast<double>(all);
}

FreeSpaceCheck::FreeSpaceCheck(const std::vector<Vector3f>& source,
                               const std::vector<Vector3f>& target, const FreeSpaceParams& params)
    : source_(source), target_(target), source_image_(source, params), target_image_(target, params) {}

FreeSpaceConflicts FreeSpaceCheck::conflicts(const Isometry3d& T_target_source) const {
  FreeSpaceConflicts c;
  c.num_source = source_.size();
  c.num_target = target_.size();
  c.source_in_target = target_image_.countConflicts(source_, T_target_source);
  c.target_in_source = source_image_.countConflicts(target_, T_target_source.inverse());
  return c;
}

std::size_t chooseByFreeSpace(const std::vector<Isometry3d>& T_target_source,
                              const std::vector<double>& scores, const FreeSpaceCheck& check,
                              double weight) {
  if (scores.size() != T_target_source.size())
    throw ContractError("chooseByFreeSpace: one score per pose");
  std::size_t best = 0;
  double best_value = -std::numeric_limits<double>::infinity();
  for (std::size_t k = 0; k < T_target_source.size(); ++k) {
    const double value =
        scores[k] * std::max(0.0, 1.0 - weight * check.conflicts(T_target_source[k]).ratio());
    if (value > best_value) {
      best_value = value;
      best = k;
    }
  }
  return best;
}

}  // namespace obm::registration
