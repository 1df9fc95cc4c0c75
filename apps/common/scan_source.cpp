#include "scan_source.hpp"

#include <filesystem>
#include <memory>
#include <mutex>

#include "obm/config/config_node.hpp"
#include "obm/core/cloud_ops.hpp"
#include "obm/core/errors.hpp"
#include "obm/core/log.hpp"
#include "obm/io/kitti.hpp"

namespace fs = std::filesystem;

namespace obm::apps {

ScanSourceConfig ScanSourceConfig::load(const ConfigNode& node) {
  ScanSourceConfig c;
  node.checkKeys({"source", "dir", "sequences", "val_sequences", "frame_gap", "voxel", "min_range",
                  "max_range"});
  std::string source = "kitti";
  node.get("source", source);
  if (source != "kitti")
    throw ConfigError(node.where("source") + ": scan pairs need source 'kitti', not '" + source +
                      "'");
  node.get("dir", c.dir);
  node.get("sequences", c.sequences);
  node.get("val_sequences", c.val_sequences);
  node.get("frame_gap", c.frame_gap);
  node.get("voxel", c.voxel);
  node.get("min_range", c.min_range);
  node.get("max_range", c.max_range);
  if (c.sequences.empty()) throw ConfigError(node.where("sequences") + ": no training sequence");
  if (c.frame_gap < 1) throw ConfigError(node.where("frame_gap") + ": must be >= 1");
  if (!(c.voxel >= 0.0)) throw ConfigError(node.where("voxel") + ": must be >= 0");
  if (c.min_range < 0.0 || c.max_range < 0.0)
    throw ConfigError(node.where("max_range") + ": ranges must be >= 0");
  return c;
}

namespace {

std::string sequenceFolder(const ScanSourceConfig& c, const std::string& name) {
  const fs::path base(c.dir.empty() ? "." : c.dir);
  for (const fs::path& p : {base / "sequences" / name, base / name, fs::path(name)})
    if (fs::is_directory(p / "velodyne")) return p.string();
  throw IoError((base / name).string() + ": KITTI sequence '" + name +
                "' not found (looked for velodyne/ in DIR/sequences/" + name + ", DIR/" + name +
                " and " + name + ")");
}

std::vector<std::shared_ptr<const io::KittiSequence>> openAll(
    const ScanSourceConfig& c, const std::vector<std::string>& names) {
  std::vector<std::shared_ptr<const io::KittiSequence>> seqs;
  for (const auto& n : names) {
    auto s = std::make_shared<const io::KittiSequence>(sequenceFolder(c, n));
    if (s->size() <= static_cast<std::size_t>(c.frame_gap))
      throw FormatError(s->directory(), 0,
                        "sequence has " + std::to_string(s->size()) +
                            " scans, not more than frame_gap = " + std::to_string(c.frame_gap));
    seqs.push_back(std::move(s));
  }
  return seqs;
}

PointCloud loadScan(const io::KittiSequence& s, std::size_t i, const ScanSourceConfig& c) {
  PointCloud scan = s.scan(i);
  if (c.min_range > 0.0 || c.max_range > 0.0)
    scan = cropRange(scan, c.min_range, c.max_range > 0.0 ? c.max_range : 1e30);
  return scan;
}

/// The pair (source = scan i + gap, target = scan i): T_target_source = T_world_i⁻¹ ·
/// T_world_{i+gap}.
obmnet::RegistrationPair makePairAt(const io::KittiSequence& s, std::size_t i,
                                    const ScanSourceConfig& c, int num_points,
                                    std::mt19937_64& rng) {
  const std::size_t j = i + static_cast<std::size_t>(c.frame_gap);
  Isometry3d T = Isometry3d::Identity();
  if (s.hasGroundTruth()) {
    const auto& gt = s.groundTruthLidar();
    T = gt[i].inverse() * gt[j];
  }
  auto pair =
      obmnet::makeScanPair(loadScan(s, j, c), loadScan(s, i, c), T, c.voxel, num_points, rng);
  pair.name = s.name() + ":" + std::to_string(j) + "->" + std::to_string(i);
  return pair;
}

/// The self-pair of the curriculum: one sampled scan and a made-up motion of it.
obmnet::RegistrationPair makeSelfPair(const io::KittiSequence& s, std::size_t i,
                                      const ScanSourceConfig& c, int num_points,
                                      std::mt19937_64& rng) {
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  const double kDeg = 3.14159265358979323846 / 180.0;
  Isometry3d T_target_source = Isometry3d::Identity();
  T_target_source.linear() = (Eigen::AngleAxisd(10.0 * kDeg * u(rng), Eigen::Vector3d::UnitZ()) *
                              Eigen::AngleAxisd(1.0 * kDeg * u(rng), Eigen::Vector3d::UnitY()) *
                              Eigen::AngleAxisd(1.0 * kDeg * u(rng), Eigen::Vector3d::UnitX()))
                                 .toRotationMatrix();
  T_target_source.translation() = Eigen::Vector3d(10.0 * u(rng), 10.0 * u(rng), 0.2 * u(rng));
  obmnet::RegistrationPair pair;
  pair.target = randomSubset(voxelDownsample(loadScan(s, i, c), c.voxel),
                             static_cast<std::size_t>(num_points), rng);
  pair.source = pair.target.transformed(T_target_source.inverse(), pair.target.frame_id);
  pair.T_target_source = T_target_source;
  pair.overlap = 1.0;
  pair.name = s.name() + ":" + std::to_string(i) + " (self)";
  return pair;
}

}  // namespace

obmnet::PairSampler scanPairSampler(const ScanSourceConfig& config, int num_points,
                                    int curriculum_epochs) {
  auto seqs = openAll(config, config.sequences);
  std::vector<double> counts;
  std::size_t total = 0;
  for (const auto& s : seqs) {
    const std::size_t n = s->size() - static_cast<std::size_t>(config.frame_gap);
    counts.push_back(static_cast<double>(n));
    total += n;
  }
  OBM_LOG_INFO("obm-train", "scan pairs: " << seqs.size() << " training sequence(s), " << total
                                           << " pairs (i, i+" << config.frame_gap << ")");
  return [seqs, counts, config, num_points, curriculum_epochs](std::mt19937_64& rng, int epoch) {
    std::discrete_distribution<std::size_t> pick(counts.begin(), counts.end());
    const auto& s = *seqs[pick(rng)];
    std::uniform_int_distribution<std::size_t> at(
        0, s.size() - 1 - static_cast<std::size_t>(config.frame_gap));
    const std::size_t i = at(rng);
    if (curriculum_epochs > 0 && epoch <= curriculum_epochs) {
      const double p_self = 1.0 - static_cast<double>(epoch - 1) / curriculum_epochs;
      if (std::uniform_real_distribution<double>(0.0, 1.0)(rng) < p_self)
        return makeSelfPair(s, i, config, num_points, rng);
    }
    return makePairAt(s, i, config, num_points, rng);
  };
}

std::vector<obmnet::RegistrationPair> scanValidationPairs(const ScanSourceConfig& config,
                                                          int num_points, int n,
                                                          std::uint64_t seed) {
  std::vector<obmnet::RegistrationPair> pairs;
  if (config.val_sequences.empty() || n <= 0) return pairs;
  const auto seqs = openAll(config, config.val_sequences);
  for (const auto& s : seqs)
    if (!s->hasGroundTruth())
      throw IoError(s->directory() +
                    ": validation sequence without ground truth (poses.txt) cannot be scored");
  std::mt19937_64 rng(seed);
  const int per = (n + static_cast<int>(seqs.size()) - 1) / static_cast<int>(seqs.size());
  for (const auto& s : seqs) {
    const std::size_t last = s->size() - 1 - static_cast<std::size_t>(config.frame_gap);
    for (int k = 0; k < per && static_cast<int>(pairs.size()) < n; ++k) {
      // Evenly spaced along the sequence, so the validation covers all of it.
      const std::size_t i =
          per > 1 ? (last * static_cast<std::size_t>(k)) / static_cast<std::size_t>(per - 1) : 0;
      pairs.push_back(makePairAt(*s, i, config, num_points, rng));
    }
  }
  return pairs;
}

}  // namespace obm::apps
