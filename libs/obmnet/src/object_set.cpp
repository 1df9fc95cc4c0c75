#include "obm/obmnet/object_set.hpp"

#include <algorithm>

#include "obm/config/config_node.hpp"
#include "obm/core/log.hpp"

namespace obm::obmnet {

ObjectSetOptions ObjectSetOptions::load(const ConfigNode& node) {
  ObjectSetOptions o;
  node.checkKeys({"surface_points", "keep_points", "val_fraction", "test_fraction", "seed"});
  node.get("surface_points", o.surface_points);
  node.get("keep_points", o.keep_points);
  node.get("val_fraction", o.val_fraction);
  node.get("test_fraction", o.test_fraction);
  node.get("seed", o.seed);
  if (o.surface_points < 8) throw ConfigError(node.where("surface_points") + ": must be >= 8");
  if (o.keep_points < 8 || o.keep_points > o.surface_points)
    throw ConfigError(node.where("keep_points") + ": must be in [8, surface_points]");
  if (o.val_fraction < 0 || o.test_fraction < 0 || o.val_fraction + o.test_fraction >= 1)
    throw ConfigError(node.where("val_fraction") + ": fractions must be >= 0 and sum to < 1");
  return o;
}

ObjectSet buildObjectSet(const std::vector<TriangleMesh>& meshes, const ObjectSetOptions& options) {
  ObjectSet set;
  for (const auto& mesh : meshes) {
    if (!(mesh.area() > 0.0)) {
      OBM_LOG_WARN("objects", "mesh '" << mesh.name << "' has no surface area; skipped");
      continue;
    }
    // Seeded by the name, so a mesh gets the same points whatever else is in the folder.
    std::uint64_t h = 1469598103934665603ull ^ options.seed;
    for (unsigned char c : mesh.name) h = (h ^ c) * 1099511628211ull;
    std::mt19937_64 rng(h);
    PointCloud c = sampleSurface(mesh, static_cast<std::size_t>(options.surface_points), rng);
    // normalizeToSphere, with its centre and scale kept for the reference samples.
    const Vector3f centre = c.centroid();
    float r = 0.f;
    for (auto& p : c.points) {
      p -= centre;
      r = std::max(r, p.norm());
    }
    const float scale = r > 0.f ? 1.0f / r : 1.0f;
    for (auto& p : c.points) p *= scale;
    c.points.resize(static_cast<std::size_t>(options.keep_points));
    c.frame_id = mesh.name;
    PointCloud ref;
    if (options.reference_points > 0) {
      // Drawn after the object's points, from the same stream: those do not change.
      ref = sampleSurface(mesh, static_cast<std::size_t>(options.reference_points), rng);
      for (auto& p : ref.points) p = (p - centre) * scale;
      ref.frame_id = mesh.name;
    }
    const Split split = splitForName(mesh.name, options.val_fraction, options.test_fraction);
    auto& points = split == Split::Train        ? set.train
                   : split == Split::Validation ? set.val
                                                : set.test;
    auto& refs = split == Split::Train        ? set.train_reference
                 : split == Split::Validation ? set.val_reference
                                              : set.test_reference;
    points.push_back(std::move(c));
    if (options.reference_points > 0) refs.push_back(std::move(ref));
  }
  return set;
}

}  // namespace obm::obmnet
