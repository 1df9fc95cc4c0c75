#include "obm/registration/factory.hpp"

#include <filesystem>

#include "obm/config/config_node.hpp"
#include "obm/core/errors.hpp"
#include "obm/registration/icp.hpp"

namespace obm::registration {

ObmNetMatcherParams ObmNetMatcherParams::load(const ConfigNode& node) {
  ObmNetMatcherParams p;
  node.checkKeys({"model_path",
                  "num_points",
                  "threads",
                  "seed",
                  "denoise_neighbors",
                  "soft_sampling",
                  "pre_align",
                  "keep_init_if_better",
                  "overlap_stage_keep",
                  "overlap_stage_gate_factor",
                  "yaw_hypotheses",
                  "refine_hypotheses",
                  "init_headings",
                  "init_headings_gate",
                  "init_headings_margin",
                  "start_turn_deg",
                  "start_turn_axes",
                  "iterations",
                  "spatial_sigma",
                  "ransac_iterations",
                  "ransac_candidates",
                  "ransac_inlier_spacing",
                  "ransac_max_turn_deg",
                  "start_heading_margin",
                  "min_consensus",
                  "select_by_consensus",
                  "search_candidates",
                  "search",
                  "choice_plane_distance",
                  "choice_inlier_power",
                  "choice_free_space_weight",
                  "hypothesis_free_space_weight",
                  "free_space"});
  p.network.model_path = node.required<std::string>("model_path");
  node.get("num_points", p.network.num_points);
  node.get("threads", p.network.threads);
  node.get("seed", p.network.seed);
  node.get("denoise_neighbors", p.network.denoise_neighbors);
  node.get("soft_sampling", p.network.soft_sampling);
  node.get("pre_align", p.pre_align);
  node.get("keep_init_if_better", p.keep_init_if_better);
  node.get("overlap_stage_keep", p.overlap_stage_keep);
  node.get("overlap_stage_gate_factor", p.overlap_stage_gate_factor);
  node.get("yaw_hypotheses", p.network.yaw_hypotheses);
  if (p.network.yaw_hypotheses < 0) throw ConfigError(node.where("yaw_hypotheses") + ": must be >= 0");
  node.get("iterations", p.network.iterations);
  if (p.network.iterations < 0)
    throw ConfigError(node.where("iterations") + ": must be >= 0 (0 = the model's)");
  node.get("spatial_sigma", p.network.spatial_sigma);
  if (!(p.network.spatial_sigma >= 0.0 || p.network.spatial_sigma == -1.0))
    throw ConfigError(node.where("spatial_sigma") + ": must be >= 0, or -1 for the model's");
  node.get("ransac_iterations", p.network.ransac_iterations);
  if (p.network.ransac_iterations < 0)
    throw ConfigError(node.where("ransac_iterations") + ": must be >= 0 (0 = off)");
  node.get("ransac_candidates", p.network.ransac_candidates);
  if (p.network.ransac_candidates < 1 || p.network.ransac_candidates > 4)
    throw ConfigError(node.where("ransac_candidates") + ": must be in [1, 4]");
  node.get("ransac_inlier_spacing", p.network.ransac_inlier_spacing);
  if (!(p.network.ransac_inlier_spacing > 0.0))
    throw ConfigError(node.where("ransac_inlier_spacing") + ": must be > 0");
  node.get("start_heading_margin", p.network.start_heading_margin);
  if (!(p.network.start_heading_margin >= 1.0))
    throw ConfigError(node.where("start_heading_margin") + ": must be >= 1 (1 = no preference)");
  node.get("min_consensus", p.network.min_consensus);
  if (!(p.network.min_consensus >= 0.0 && p.network.min_consensus <= 1.0))
    throw ConfigError(node.where("min_consensus") + ": must be in [0, 1] (0 = off)");
  node.get("ransac_max_turn_deg", p.network.ransac_max_turn_deg);
  if (!(p.network.ransac_max_turn_deg > 0.0 && p.network.ransac_max_turn_deg <= 180.0))
    throw ConfigError(node.where("ransac_max_turn_deg") + ": must be in (0, 180]");
  node.get("select_by_consensus", p.network.select_by_consensus);
  node.get("refine_hypotheses", p.refine_hypotheses);
  if (p.refine_hypotheses < 0)
    throw ConfigError(node.where("refine_hypotheses") + ": must be >= 0 (0 = all)");
  node.get("init_headings", p.init_headings);
  node.get("init_headings_gate", p.init_headings_gate);
  node.get("init_headings_margin", p.init_headings_margin);
  if (!(p.init_headings_margin >= 1.0))
    throw ConfigError(node.where("init_headings_margin") + ": must be >= 1");
  if (!(p.init_headings_gate >= 0.0))
    throw ConfigError(node.where("init_headings_gate") + ": must be >= 0 (0 = the ICP's own)");
  if (p.init_headings < 0)
    throw ConfigError(node.where("init_headings") + ": must be >= 0 (0 = off)");
  node.get("start_turn_deg", p.start_turn_deg);
  if (!(p.start_turn_deg >= 0.0 && p.start_turn_deg <= 180.0))
    throw ConfigError(node.where("start_turn_deg") + ": must be in [0, 180] (0 = off)");
  node.get("search_candidates", p.search_candidates);
  if (p.search_candidates < 0)
    throw ConfigError(node.where("search_candidates") + ": must be >= 0 (0 = off)");
  if (node.has("search")) p.search = CorrelativeSearchParams::load(node.child("search"));
  node.get("choice_plane_distance", p.choice_plane_distance);
  if (!(p.choice_plane_distance >= 0.0))
    throw ConfigError(node.where("choice_plane_distance") + ": must be >= 0 (0 = off)");
  node.get("choice_inlier_power", p.choice_inlier_power);
  if (!(p.choice_inlier_power >= 0.0))
    throw ConfigError(node.where("choice_inlier_power") + ": must be >= 0 (0 = off)");
  node.get("choice_free_space_weight", p.choice_free_space_weight);
  if (!(p.choice_free_space_weight >= 0.0))
    throw ConfigError(node.where("choice_free_space_weight") + ": must be >= 0 (0 = off)");
  node.get("hypothesis_free_space_weight", p.hypothesis_free_space_weight);
  if (!(p.hypothesis_free_space_weight >= 0.0))
    throw ConfigError(node.where("hypothesis_free_space_weight") + ": must be >= 0 (0 = off)");
  if (node.has("free_space")) p.free_space = FreeSpaceParams::load(node.child("free_space"));
  node.get("start_turn_axes", p.start_turn_axes);
  if (const std::string why = startTurnAxesError(p.start_turn_axes); !why.empty())
    throw ConfigError(node.where("start_turn_axes") + ": " + why);
  if (!(p.overlap_stage_keep >= 0.0 && p.overlap_stage_keep <= 1.0))
    throw ConfigError(node.where("overlap_stage_keep") + ": must be in [0, 1]");
  if (!(p.overlap_stage_gate_factor >= 1.0))
    throw ConfigError(node.where("overlap_stage_gate_factor") + ": must be >= 1");
  if (p.network.model_path.empty()) throw ConfigError(node.where("model_path") + ": must not be empty");
  if (p.network.num_points < 0) throw ConfigError(node.where("num_points") + ": must be >= 0");
  if (p.network.threads < 1) throw ConfigError(node.where("threads") + ": must be >= 1");
  if (p.network.soft_sampling < -1 || p.network.soft_sampling > 1)
    throw ConfigError(node.where("soft_sampling") + ": must be -1 (the model's), 0 or 1");
  if (p.network.denoise_neighbors < 0)
    throw ConfigError(node.where("denoise_neighbors") + ": must be >= 0");
  // A relative model path is relative to the YAML file that names it.
  const std::filesystem::path model(p.network.model_path);
  if (model.is_relative() && !node.file().empty() && std::filesystem::exists(node.file()))
    p.network.model_path = (std::filesystem::path(node.file()).parent_path() / model).string();
  return p;
}

namespace {
constexpr MatcherKind kKinds[] = {MatcherKind::Icp, MatcherKind::ObmNet, MatcherKind::ObmNetIcp,
                                  MatcherKind::ObmmIcp};
}  // namespace

const char* toString(MatcherKind kind) {
  switch (kind) {
    case MatcherKind::Icp:
      return "icp";
    case MatcherKind::ObmNet:
      return "obmnet";
    case MatcherKind::ObmNetIcp:
      return "obmnet+icp";
    case MatcherKind::ObmmIcp:
      return "obmm+icp";
  }
  return "unknown";
}

MatcherKind parseMatcherKind(const std::string& name, const std::string& where) {
  std::string names;
  for (const MatcherKind k : kKinds) {
    if (name == toString(k)) return k;
    names += (names.empty() ? "" : ", ") + std::string(toString(k));
  }
  throw ConfigError(where + ": unknown matcher type '" + name + "' (" + names + ")");
}

namespace {

/// `over` merged into a copy of `base`: maps key by key (recursively), anything else replaced.
YAML::Node mergedYaml(const YAML::Node& base, const YAML::Node& over) {
  if (!base.IsMap() || !over.IsMap()) return YAML::Clone(over);
  YAML::Node out = YAML::Clone(base);
  for (const auto& kv : over) {
    const std::string key = kv.first.as<std::string>();
    out[key] = out[key] ? mergedYaml(out[key], kv.second) : YAML::Clone(kv.second);
  }
  return out;
}

/// A `matcher:` map with `preset: FILE` (relative to the YAML that names it): the preset's
/// `matcher:` with this map's other keys laid over it. The preset's model path is made absolute
/// first, since the merged map is read as this file's.
ConfigNode withPreset(const ConfigNode& node) {
  const std::string name = node.required<std::string>("preset");
  std::filesystem::path file(name);
  if (file.is_relative() && !node.file().empty())
    file = std::filesystem::path(node.file()).parent_path() / file;
  if (!std::filesystem::exists(file))
    throw ConfigError(node.where("preset") + ": preset '" + file.string() + "' not found");
  const ConfigNode root = ConfigNode::loadFile(file.string());
  if (!root.has("matcher"))
    throw ConfigError(root.where("matcher") + ": a preset needs a `matcher:` map");
  YAML::Node base = YAML::Clone(root.child("matcher").yaml());
  if (base["obmnet"] && base["obmnet"]["model_path"]) {
    const std::filesystem::path model(base["obmnet"]["model_path"].as<std::string>());
    if (model.is_relative())
      base["obmnet"]["model_path"] =
          (file.parent_path() / model).lexically_normal().string();
  }
  YAML::Node over = YAML::Clone(node.yaml());
  over.remove("preset");
  // The key path of `node` (where() is "file: path"), so errors keep naming this file's keys.
  const std::string where = node.where();
  const std::string prefix = (node.file().empty() ? std::string("<config>") : node.file()) + ": ";
  const std::string path = where.rfind(prefix, 0) == 0 ? where.substr(prefix.size()) : where;
  return ConfigNode(mergedYaml(base, over), node.file(), path);
}

}  // namespace

ScanMatcherConfig ScanMatcherConfig::load(const ConfigNode& node_in) {
  if (node_in.has("preset")) return load(withPreset(node_in));
  const ConfigNode& node = node_in;
  ScanMatcherConfig c;
  node.checkKeys({"type", "icp", "obmnet", "confidence"});
  std::string type = toString(c.type);
  node.get("type", type);
  c.type = parseMatcherKind(type, node.where("type"));
  c.icp = IcpParams::load(node.child("icp"));
  c.confidence = ConfidenceParams::load(node.child("confidence"));
  if (usesNetwork(c.type)) {
    if (!node.has("obmnet"))
      throw ConfigError(node.where("obmnet") + ": required for type '" + type + "'");
    c.obmnet = ObmNetMatcherParams::load(node.child("obmnet"));
  } else if (node.has("obmnet")) {
    c.obmnet = ObmNetMatcherParams::load(node.child("obmnet"));  // checked, unused
  }
  return c;
}

std::unique_ptr<ScanMatcher> makeScanMatcher(const ScanMatcherConfig& config) {
  switch (config.type) {
    case MatcherKind::Icp:
      return std::make_unique<IcpMatcher>(config.icp, config.confidence);
    case MatcherKind::ObmNet:
      return std::make_unique<ObmNetMatcher>(config.obmnet, config.icp, config.confidence);
    case MatcherKind::ObmNetIcp:
      return std::make_unique<ObmNetIcpMatcher>(config.obmnet, config.icp, config.confidence);
    case MatcherKind::ObmmIcp:
      return std::make_unique<ObmmIcpMatcher>(config.obmnet, config.icp, config.confidence);
  }
  throw ContractError("makeScanMatcher: invalid MatcherKind");
}

}  // namespace obm::registration
