#include "obm/bench/preset.hpp"

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <sstream>

#include "obm/config/config_node.hpp"
#include "obm/config/overrides.hpp"
#include "obm/core/errors.hpp"

namespace obm::bench {
namespace {

struct ProtocolName {
  Protocol protocol;
  const char* name;
  const char* preset;
};
constexpr ProtocolName kProtocols[] = {
    {Protocol::Clean, "clean", "objects"},
    {Protocol::Jitter, "jitter", "objects_noise"},
    {Protocol::Outliers, "outliers", "objects_noise"},
    {Protocol::Partial, "partial", "objects"},
    {Protocol::PartialNoise, "partial_noise", "objects_noise"},
    {Protocol::Resampled, "resampled", "objects_resampled"},
    {Protocol::Indoor, "indoor", "fragments"},
    {Protocol::Icl, "icl", "fragments"},
    {Protocol::RgbdFrames, "rgbd_frames", "rgbd_frames"},
    {Protocol::Kitti, "kitti", "lidar"},
};

double median(std::vector<double> v) {
  if (v.empty()) return 0.0;
  const auto mid = v.begin() + static_cast<std::ptrdiff_t>(v.size() / 2);
  std::nth_element(v.begin(), mid, v.end());
  return *mid;
}

}  // namespace

Protocol parseProtocol(const std::string& name, const std::string& where) {
  std::string names;
  for (const auto& p : kProtocols) {
    if (name == p.name) return p.protocol;
    names += (names.empty() ? "" : ", ") + std::string(p.name);
  }
  throw ConfigError(where + ": unknown protocol '" + name + "' (" + names + ")");
}

const char* toString(Protocol protocol) {
  for (const auto& p : kProtocols)
    if (p.protocol == protocol) return p.name;
  return "pairs";
}

std::string presetName(Protocol protocol) {
  for (const auto& p : kProtocols)
    if (p.protocol == protocol) return p.preset;
  throw ContractError("presetName: a folder of pairs has no protocol preset (presetForPairs)");
}

BenchParams BenchParams::load(const ConfigNode& node) {
  BenchParams b;
  node.checkKeys({"data_config", "recall_deg", "recall_trans", "open3d_unit", "ransac_iterations",
                  "start_turn_deg", "score_free_space", "surface_error", "rows"});
  node.get("data_config", b.data_config);
  node.get("recall_deg", b.recall_deg);
  node.get("recall_trans", b.recall_trans);
  node.get("open3d_unit", b.open3d_unit);
  node.get("ransac_iterations", b.ransac_iterations);
  node.get("start_turn_deg", b.start_turn_deg);
  node.get("score_free_space", b.score_free_space);
  node.get("surface_error", b.surface_error);
  node.get("rows", b.rows);
  if (!(b.recall_deg > 0.0)) throw ConfigError(node.where("recall_deg") + ": must be > 0");
  if (!(b.recall_trans > 0.0)) throw ConfigError(node.where("recall_trans") + ": must be > 0");
  if (!(b.open3d_unit > 0.0)) throw ConfigError(node.where("open3d_unit") + ": must be > 0");
  if (b.ransac_iterations < 1)
    throw ConfigError(node.where("ransac_iterations") + ": must be >= 1");
  if (!(b.start_turn_deg >= 0.0 && b.start_turn_deg <= 180.0))
    throw ConfigError(node.where("start_turn_deg") + ": must be in [0, 180] (0 = off)");
  if (!(b.surface_error >= 0.0))
    throw ConfigError(node.where("surface_error") + ": must be >= 0 (0 = off)");
  // A data config named relative to the preset is relative to the preset's folder.
  const std::filesystem::path data(b.data_config);
  if (!b.data_config.empty() && data.is_relative() && !node.file().empty())
    b.data_config =
        (std::filesystem::path(node.file()).parent_path() / data).lexically_normal().string();
  return b;
}

Preset Preset::load(const std::string& file, const std::vector<std::string>& assignments,
                    const std::vector<std::pair<std::string, std::string>>& texts) {
  ConfigNode root = ConfigNode::loadFile(file);
  for (const auto& [path, text] : texts) setValue(root, path, YAML::Node(text));
  applyOverrides(root, assignments);
  root.checkKeys({"matcher", "benchmark"});
  Preset p;
  p.file = file;
  p.name = std::filesystem::path(file).stem().string();
  p.matcher = registration::ScanMatcherConfig::load(root.child("matcher"));
  p.bench = BenchParams::load(root.child("benchmark"));
  return p;
}

std::string presetForPairs(const std::vector<obmnet::RegistrationPair>& pairs, std::string* why) {
  std::vector<double> ranges, front;
  for (const auto& pair : pairs) {
    const auto& pts = pair.target.points;
    if (pts.empty()) continue;
    std::vector<double> r;
    std::size_t ahead = 0;
    r.reserve(pts.size());
    for (const auto& q : pts) {
      r.push_back(static_cast<double>(q.norm()));
      if (q.z() > 0.0f) ++ahead;
    }
    ranges.push_back(median(std::move(r)));
    front.push_back(static_cast<double>(ahead) / static_cast<double>(pts.size()));
  }
  const double range = median(ranges);
  const double ahead = median(front);
  std::string kind = "objects_resampled";
  if (range > 5.0)
    kind = "lidar";
  else if (ahead >= 0.9 && range >= 0.3)
    kind = "rgbd_frames";
  if (why) {
    std::ostringstream os;
    os << "median range " << range << ", share of points at z > 0 " << ahead;
    *why = os.str();
  }
  return kind;
}

}  // namespace obm::bench
