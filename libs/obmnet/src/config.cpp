#include "obm/obmnet/config.hpp"

#include <yaml-cpp/yaml.h>

#include "obm/config/config_node.hpp"
#include "obm/core/errors.hpp"

namespace obm::obmnet {

ObmNetConfig ObmNetConfig::load(const ConfigNode& node) {
  ObmNetConfig c;
  node.checkKeys({"emb_dims", "dim", "k1", "k2", "n_keypoints", "n_samples", "n_iters", "nn_margin",
                  "loss_margin", "beta", "tau_min", "use_overlap_sampling", "use_bias_prediction",
                  "use_nmm", "nmm_score_grad", "planar", "voxel_keypoints", "neighbor_loss_nearest",
                  "shared_centroid", "edge_normals", "normal_neighbours",
                  "ground_band", "soft_inference_sampling", "seed", "match_contrast",
                  "match_spatial_sigma"});
  node.get("emb_dims", c.emb_dims);
  node.get("dim", c.dim);
  node.get("k1", c.k1);
  node.get("k2", c.k2);
  node.get("n_keypoints", c.n_keypoints);
  node.get("n_samples", c.n_samples);
  node.get("n_iters", c.n_iters);
  node.get("nn_margin", c.nn_margin);
  node.get("loss_margin", c.loss_margin);
  node.get("beta", c.beta);
  node.get("tau_min", c.tau_min);
  node.get("use_overlap_sampling", c.use_overlap_sampling);
  node.get("use_bias_prediction", c.use_bias_prediction);
  node.get("use_nmm", c.use_nmm);
  node.get("nmm_score_grad", c.nmm_score_grad);
  node.get("planar", c.planar);
  node.get("voxel_keypoints", c.voxel_keypoints);
  node.get("neighbor_loss_nearest", c.neighbor_loss_nearest);
  node.get("shared_centroid", c.shared_centroid);
  node.get("edge_normals", c.edge_normals);
  node.get("normal_neighbours", c.normal_neighbours);
  node.get("ground_band", c.ground_band);
  node.get("soft_inference_sampling", c.soft_inference_sampling);
  node.get("seed", c.seed);
  node.get("match_contrast", c.match_contrast);
  node.get("match_spatial_sigma", c.match_spatial_sigma);
  c.validate(node.where());
  return c;
}

void ObmNetConfig::validate(const std::string& where) const {
  auto fail = [&](const std::string& key, const std::string& what) {
    throw ConfigError(where + (where.empty() || where.back() == ' ' ? "" : ": ") + key + ": " +
                      what);
  };
  if (emb_dims < 1) fail("emb_dims", "must be >= 1");
  if (dim < 1) fail("dim", "must be >= 1");
  if (k1 < 2) fail("k1", "must be >= 2 (the point itself is one of its neighbours)");
  if (k2 < 1) fail("k2", "must be >= 1");
  if (n_keypoints < 1) fail("n_keypoints", "must be >= 1");
  if (n_samples < 1) fail("n_samples", "must be >= 1");
  if (n_iters < 1) fail("n_iters", "must be >= 1");
  if (!(loss_margin > 0.0)) fail("loss_margin", "must be > 0");
  if (!(match_contrast >= 0.0)) fail("match_contrast", "must be >= 0");
  if (!(match_spatial_sigma >= 0.0)) fail("match_spatial_sigma", "must be >= 0 (0 = off)");
  if (!(beta >= 0.0)) fail("beta", "must be >= 0");
  if (!(tau_min > 0.0)) fail("tau_min", "must be > 0");
  if (!(ground_band >= 0.0)) fail("ground_band", "must be >= 0");
  if (normal_neighbours < 3) fail("normal_neighbours", "must be >= 3 (a plane needs three points)");
  if (use_bias_prediction && !use_overlap_sampling)
    fail("use_bias_prediction",
         "needs use_overlap_sampling: α weights the sampled overlap region, which OS provides");
}

std::string ObmNetConfig::toYaml() const {
  YAML::Emitter out;
  out.SetDoublePrecision(17);
  out << YAML::BeginMap;
  out << YAML::Key << "emb_dims" << YAML::Value << emb_dims;
  out << YAML::Key << "dim" << YAML::Value << dim;
  out << YAML::Key << "k1" << YAML::Value << k1;
  out << YAML::Key << "k2" << YAML::Value << k2;
  out << YAML::Key << "n_keypoints" << YAML::Value << n_keypoints;
  out << YAML::Key << "n_samples" << YAML::Value << n_samples;
  out << YAML::Key << "n_iters" << YAML::Value << n_iters;
  out << YAML::Key << "nn_margin" << YAML::Value << nn_margin;
  out << YAML::Key << "loss_margin" << YAML::Value << loss_margin;
  out << YAML::Key << "beta" << YAML::Value << beta;
  out << YAML::Key << "tau_min" << YAML::Value << tau_min;
  out << YAML::Key << "use_overlap_sampling" << YAML::Value << use_overlap_sampling;
  out << YAML::Key << "use_bias_prediction" << YAML::Value << use_bias_prediction;
  out << YAML::Key << "use_nmm" << YAML::Value << use_nmm;
  out << YAML::Key << "nmm_score_grad" << YAML::Value << nmm_score_grad;
  // Written only when set, so that models trained before these keys existed keep their
  // embedded text byte for byte.
  if (planar) out << YAML::Key << "planar" << YAML::Value << planar;
  if (voxel_keypoints) out << YAML::Key << "voxel_keypoints" << YAML::Value << voxel_keypoints;
  if (neighbor_loss_nearest)
    out << YAML::Key << "neighbor_loss_nearest" << YAML::Value << neighbor_loss_nearest;
  if (shared_centroid) out << YAML::Key << "shared_centroid" << YAML::Value << shared_centroid;
  if (edge_normals) out << YAML::Key << "edge_normals" << YAML::Value << edge_normals;
  if (edge_normals)
    out << YAML::Key << "normal_neighbours" << YAML::Value << normal_neighbours;
  if (ground_band > 0.0) out << YAML::Key << "ground_band" << YAML::Value << ground_band;
  if (soft_inference_sampling)
    out << YAML::Key << "soft_inference_sampling" << YAML::Value << soft_inference_sampling;
  if (match_contrast != ObmNetConfig{}.match_contrast)
    out << YAML::Key << "match_contrast" << YAML::Value << match_contrast;
  if (match_spatial_sigma > 0.0)
    out << YAML::Key << "match_spatial_sigma" << YAML::Value << match_spatial_sigma;
  out << YAML::Key << "seed" << YAML::Value << seed;
  out << YAML::EndMap;
  return std::string(out.c_str()) + "\n";
}

TeacherParams TeacherParams::load(const ConfigNode& node) {
  node.checkKeys({"icp_iterations", "initial_max_distance", "max_distance", "match_radius",
                  "from_identity", "point_to_plane", "normal_neighbours", "start_rotation_deg",
                  "min_fitness"});
  TeacherParams p;
  node.get("icp_iterations", p.icp_iterations);
  node.get("initial_max_distance", p.initial_max_distance);
  node.get("max_distance", p.max_distance);
  node.get("match_radius", p.match_radius);
  node.get("from_identity", p.from_identity);
  node.get("point_to_plane", p.point_to_plane);
  node.get("normal_neighbours", p.normal_neighbours);
  node.get("start_rotation_deg", p.start_rotation_deg);
  node.get("min_fitness", p.min_fitness);
  if (p.icp_iterations < 0) throw ConfigError(node.where("icp_iterations") + ": must be >= 0");
  if (!(p.max_distance > 0)) throw ConfigError(node.where("max_distance") + ": must be > 0");
  if (!(p.initial_max_distance >= p.max_distance))
    throw ConfigError(node.where("initial_max_distance") + ": must be >= max_distance");
  if (!(p.match_radius > 0)) throw ConfigError(node.where("match_radius") + ": must be > 0");
  if (p.normal_neighbours < 3)
    throw ConfigError(node.where("normal_neighbours") +
                      ": must be >= 3 (a plane needs three points)");
  if (!(p.start_rotation_deg >= 0.0 && p.start_rotation_deg <= 180.0))
    throw ConfigError(node.where("start_rotation_deg") + ": must be in [0, 180]");
  if (!(p.min_fitness >= 0.0 && p.min_fitness <= 1.0))
    throw ConfigError(node.where("min_fitness") + ": must be in [0, 1]");
  return p;
}

}  // namespace obm::obmnet
