#include "obm/mapping/mapping_params.hpp"

#include <cmath>
#include <string>
#include <utility>

#include "obm/config/config_node.hpp"
#include "obm/core/errors.hpp"

namespace obm::mapping {

namespace {
/// Names the offending field in the exception so load() can point at the YAML key.
class FieldError : public ConfigError {
 public:
  FieldError(std::string field, const std::string& what)
      : ConfigError("MappingParams." + field + ": " + what),
        field_(std::move(field)),
        what_(what) {}
  const std::string& field() const noexcept { return field_; }
  const std::string& problem() const noexcept { return what_; }

 private:
  std::string field_, what_;
};

void check(bool ok, const char* field, const std::string& what) {
  if (!ok) throw FieldError(field, what);
}
}  // namespace

void MappingParams::validate() const {
  check(std::isfinite(resolution) && resolution > 0.0, "resolution", "must be > 0 [m]");
  check(std::isfinite(max_range), "max_range", "must be finite (<= 0 = unlimited)");
  check(std::isfinite(min_range) && min_range >= 0.0, "min_range", "must be >= 0 [m]");
  check(max_range <= 0.0 || min_range < max_range, "min_range", "must be below max_range");
  check(prob_hit > 0.5 && prob_hit < 1.0, "prob_hit", "must be in (0.5, 1)");
  check(prob_miss > 0.0 && prob_miss < 0.5, "prob_miss", "must be in (0, 0.5)");
  check(clamping_min > 0.0 && clamping_min < 0.5, "clamping_min", "must be in (0, 0.5)");
  check(clamping_max > 0.5 && clamping_max < 1.0, "clamping_max", "must be in (0.5, 1)");
  check(occupancy_threshold > clamping_min && occupancy_threshold < clamping_max,
        "occupancy_threshold", "must be between clamping_min and clamping_max");
  check(std::isfinite(prefilter_voxel) && prefilter_voxel >= 0.0, "prefilter_voxel",
        "must be >= 0 [m] (0 = off)");
  check(prefilter_voxel <= resolution * (1.0 + 1e-9), "prefilter_voxel",
        "must not exceed resolution (a coarser pre-filter leaves holes in surfaces)");
}

MappingParams MappingParams::load(const ConfigNode& node) {
  node.checkKeys({"resolution", "max_range", "min_range", "prob_hit", "prob_miss", "clamping_min",
                  "clamping_max", "occupancy_threshold", "prefilter_voxel", "discretize",
                  "batch_update", "lazy_update", "prune_every"});
  MappingParams p;
  node.get("resolution", p.resolution);
  node.get("max_range", p.max_range);
  node.get("min_range", p.min_range);
  node.get("prob_hit", p.prob_hit);
  node.get("prob_miss", p.prob_miss);
  node.get("clamping_min", p.clamping_min);
  node.get("clamping_max", p.clamping_max);
  node.get("occupancy_threshold", p.occupancy_threshold);
  node.get("prefilter_voxel", p.prefilter_voxel);
  node.get("discretize", p.discretize);
  node.get("batch_update", p.batch_update);
  node.get("lazy_update", p.lazy_update);
  node.get("prune_every", p.prune_every);
  try {
    p.validate();
  } catch (const FieldError& e) {
    // Re-issue with the file and key path so the message points at the YAML that holds the value.
    throw ConfigError(node.where(e.field()) + ": " + e.problem());
  }
  return p;
}

}  // namespace obm::mapping
