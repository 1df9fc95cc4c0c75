#include "obm/registration/params.hpp"

#include <cmath>

#include "obm/config/config_node.hpp"
#include "obm/core/errors.hpp"

namespace obm::registration {
namespace {

void check(bool ok, const std::string& what) {
  if (!ok) throw ContractError("registration parameters: " + what);
}

}  // namespace

PreparedTarget::Options IcpParams::targetOptions() const {
  PreparedTarget::Options o;
  o.voxel = target_voxel;
  o.normal_neighbors = normal_neighbors;
  o.min_planarity = min_planarity;
  o.threads = threads;
  o.color_gradients = color_weight > 0.0;
  return o;
}

void IcpParams::validate() const {
  check(source_voxel >= 0.0 && std::isfinite(source_voxel), "source_voxel must be >= 0");
  check(target_voxel >= 0.0 && std::isfinite(target_voxel), "target_voxel must be >= 0");
  check(normal_neighbors >= 3, "normal_neighbors must be >= 3");
  check(min_planarity >= 0.0 && min_planarity <= 1.0, "min_planarity must be in [0, 1]");
  check(max_correspondence_distance > 0.0 && std::isfinite(max_correspondence_distance),
        "max_correspondence_distance must be > 0");
  check(initial_max_correspondence_distance >= 0.0 &&
            std::isfinite(initial_max_correspondence_distance),
        "initial_max_correspondence_distance must be >= 0");
  check(anneal_factor > 0.0 && anneal_factor < 1.0, "anneal_factor must be in (0, 1)");
  check(polish_max_correspondence_distance >= 0.0 &&
            std::isfinite(polish_max_correspondence_distance),
        "polish_max_correspondence_distance must be >= 0");
  check(kernel_scale > 0.0 && std::isfinite(kernel_scale), "kernel_scale must be > 0");
  check(weak_direction_threshold >= 0.0 && weak_direction_threshold < 1.0,
        "weak_direction_threshold must be in [0, 1)");
  check(final_kernel_scale >= 0.0 && std::isfinite(final_kernel_scale),
        "final_kernel_scale must be >= 0 (0 = no final stage)");
  check(color_weight >= 0.0 && std::isfinite(color_weight), "color_weight must be >= 0");
  check(color_kernel_scale > 0.0 && std::isfinite(color_kernel_scale),
        "color_kernel_scale must be > 0");
  check(depth_noise_a > 0.0 && std::isfinite(depth_noise_a), "depth_noise_a must be > 0");
  check(depth_noise_b >= 0.0 && std::isfinite(depth_noise_b), "depth_noise_b must be >= 0");
  check(depth_noise_z0 >= 0.0 && std::isfinite(depth_noise_z0), "depth_noise_z0 must be >= 0");
  check(max_iterations >= 1, "max_iterations must be >= 1");
  check(translation_tolerance > 0.0, "translation_tolerance must be > 0");
  check(rotation_tolerance > 0.0, "rotation_tolerance must be > 0");
  check(min_correspondences >= 6, "min_correspondences must be >= 6 (six pose unknowns)");
  check(threads >= 1, "threads must be >= 1");
}

IcpParams IcpParams::load(const ConfigNode& node) {
  IcpParams p;
  node.checkKeys({"source_voxel", "target_voxel", "normal_neighbors", "min_planarity",
                  "max_correspondence_distance", "initial_max_correspondence_distance",
                  "anneal_factor", "polish_max_correspondence_distance", "metric", "point_to_point_fallback", "kernel", "kernel_scale",
                  "final_kernel_scale", "weak_direction_threshold",
                  "color_weight", "color_kernel_scale", "depth_noise_weights", "depth_noise_a",
                  "depth_noise_b", "depth_noise_z0",
                  "solver", "max_iterations", "translation_tolerance", "rotation_tolerance_deg",
                  "min_correspondences", "threads"});
  node.get("source_voxel", p.source_voxel);
  node.get("target_voxel", p.target_voxel);
  node.get("normal_neighbors", p.normal_neighbors);
  node.get("min_planarity", p.min_planarity);
  node.get("max_correspondence_distance", p.max_correspondence_distance);
  node.get("initial_max_correspondence_distance", p.initial_max_correspondence_distance);
  node.get("anneal_factor", p.anneal_factor);
  node.get("polish_max_correspondence_distance", p.polish_max_correspondence_distance);
  if (node.has("metric"))
    p.metric = parseIcpMetric(node.required<std::string>("metric"), node.where("metric"));
  node.get("point_to_point_fallback", p.point_to_point_fallback);
  if (node.has("kernel"))
    p.kernel = parseRobustKernel(node.required<std::string>("kernel"), node.where("kernel"));
  node.get("kernel_scale", p.kernel_scale);
  node.get("final_kernel_scale", p.final_kernel_scale);
  node.get("weak_direction_threshold", p.weak_direction_threshold);
  node.get("color_weight", p.color_weight);
  node.get("color_kernel_scale", p.color_kernel_scale);
  node.get("depth_noise_weights", p.depth_noise_weights);
  node.get("depth_noise_a", p.depth_noise_a);
  node.get("depth_noise_b", p.depth_noise_b);
  node.get("depth_noise_z0", p.depth_noise_z0);
  if (node.has("solver"))
    p.solver = parseIcpSolver(node.required<std::string>("solver"), node.where("solver"));
  node.get("max_iterations", p.max_iterations);
  node.get("translation_tolerance", p.translation_tolerance);
  node.getDegAsRad("rotation_tolerance_deg", p.rotation_tolerance);
  node.get("min_correspondences", p.min_correspondences);
  node.get("threads", p.threads);
  try {
    p.validate();
  } catch (const ContractError& e) {
    throw ConfigError(node.where() + ": " + e.what());
  }
  return p;
}

void ConfidenceParams::validate() const {
  check(inlier_threshold > 0.0, "inlier_threshold must be > 0");
  check(min_sigma > 0.0, "min_sigma must be > 0");
  check(information_scale > 0.0, "information_scale must be > 0");
  check(inlier_ratio_ref > 0.0 && inlier_ratio_ref <= 1.0, "inlier_ratio_ref must be in (0, 1]");
  check(overlap_ref > 0.0 && overlap_ref <= 1.0, "overlap_ref must be in (0, 1]");
  check(conditioning_ref > 0.0, "conditioning_ref must be > 0");
  check(degeneracy_threshold >= 0.0, "degeneracy_threshold must be >= 0");
  check(color_inlier_threshold >= 0.0, "color_inlier_threshold must be >= 0 (0 = off)");
}

ConfidenceParams ConfidenceParams::load(const ConfigNode& node) {
  ConfidenceParams p;
  node.checkKeys({"inlier_threshold", "min_sigma", "information_scale", "inlier_ratio_ref",
                  "overlap_ref", "conditioning_ref", "degeneracy_threshold",
                  "color_inlier_threshold"});
  node.get("inlier_threshold", p.inlier_threshold);
  node.get("min_sigma", p.min_sigma);
  node.get("information_scale", p.information_scale);
  node.get("inlier_ratio_ref", p.inlier_ratio_ref);
  node.get("overlap_ref", p.overlap_ref);
  node.get("conditioning_ref", p.conditioning_ref);
  node.get("degeneracy_threshold", p.degeneracy_threshold);
  node.get("color_inlier_threshold", p.color_inlier_threshold);
  try {
    p.validate();
  } catch (const ContractError& e) {
    throw ConfigError(node.where() + ": " + e.what());
  }
  return p;
}

IcpMetric parseIcpMetric(const std::string& name, const std::string& where) {
  if (name == "point_to_plane") return IcpMetric::PointToPlane;
  if (name == "point_to_point") return IcpMetric::PointToPoint;
  throw ConfigError(where + ": unknown ICP metric '" + name + "' (point_to_plane, point_to_point)");
}

std::string toString(IcpMetric metric) {
  return metric == IcpMetric::PointToPlane ? "point_to_plane" : "point_to_point";
}

IcpSolver parseIcpSolver(const std::string& name, const std::string& where) {
  if (name == "gauss_newton" || name == "gn") return IcpSolver::GaussNewton;
  if (name == "levenberg_marquardt" || name == "lm") return IcpSolver::LevenbergMarquardt;
  throw ConfigError(where + ": unknown ICP solver '" + name +
                    "' (gauss_newton, levenberg_marquardt)");
}

std::string toString(IcpSolver solver) {
  return solver == IcpSolver::GaussNewton ? "gauss_newton" : "levenberg_marquardt";
}

}  // namespace obm::registration
