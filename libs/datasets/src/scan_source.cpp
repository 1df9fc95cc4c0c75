#include "obm/datasets/scan_source.hpp"

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <memory>
#include <mutex>

#include "obm/config/config_node.hpp"
#include "obm/core/cloud_ops.hpp"
#include "obm/core/errors.hpp"
#include "obm/core/log.hpp"
#include "obm/core/se3.hpp"
#include "obm/io/kitti.hpp"

namespace fs = std::filesystem;

namespace obm::datasets {

ScanSourceConfig ScanSourceConfig::load(const ConfigNode& node) {
  ScanSourceConfig c;
  node.checkKeys({"source", "dir", "sequences", "val_sequences", "frame_gap", "frame_gaps",
                  "voxel", "min_range", "max_range", "ground_band", "voxel_keypoints", "surface_points", "loop_fraction",
                  "loop_max_distance", "loop_min_separation", "yaw_augment_deg", "pose_labels",
                  "label_yaw_hypotheses"});
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
  node.get("ground_band", c.ground_band);
  node.get("frame_gaps", c.frame_gaps);
  node.get("voxel_keypoints", c.voxel_keypoints);
  node.get("surface_points", c.surface_points);
  node.get("loop_fraction", c.loop_fraction);
  node.get("loop_max_distance", c.loop_max_distance);
  node.get("loop_min_separation", c.loop_min_separation);
  node.get("yaw_augment_deg", c.yaw_augment_deg);
  node.get("pose_labels", c.pose_labels);
  node.get("label_yaw_hypotheses", c.label_yaw_hypotheses);
  if (c.surface_points < 0) throw ConfigError(node.where("surface_points") + ": must be >= 0");
  if (c.label_yaw_hypotheses < 0)
    throw ConfigError(node.where("label_yaw_hypotheses") + ": must be >= 0");
  if (c.pose_labels.find('/') != std::string::npos)
    throw ConfigError(node.where("pose_labels") + ": '" + c.pose_labels +
                      "': a file name inside each training sequence's folder, not a path");
  for (int g : c.frame_gaps)
    if (g < 1) throw ConfigError(node.where("frame_gaps") + ": every gap must be >= 1");
  if (!(c.loop_fraction >= 0.0 && c.loop_fraction <= 1.0))
    throw ConfigError(node.where("loop_fraction") + ": must be in [0, 1]");
  if (!(c.loop_max_distance > 0.0))
    throw ConfigError(node.where("loop_max_distance") + ": must be > 0");
  if (c.loop_min_separation < 1)
    throw ConfigError(node.where("loop_min_separation") + ": must be >= 1");
  if (!(c.yaw_augment_deg >= 0.0 && c.yaw_augment_deg <= 180.0))
    throw ConfigError(node.where("yaw_augment_deg") + ": must be in [0, 180]");
  if (c.sequences.empty()) throw ConfigError(node.where("sequences") + ": no training sequence");
  if (c.frame_gap < 1) throw ConfigError(node.where("frame_gap") + ": must be >= 1");
  if (!(c.voxel >= 0.0)) throw ConfigError(node.where("voxel") + ": must be >= 0");
  if (c.min_range < 0.0 || c.max_range < 0.0)
    throw ConfigError(node.where("max_range") + ": ranges must be >= 0");
  if (!(c.ground_band >= 0.0)) throw ConfigError(node.where("ground_band") + ": must be >= 0");
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

/// `labels`: the training sequences, whose poses come from `c.pose_labels` when it is set.
std::vector<std::shared_ptr<const io::KittiSequence>> openAll(
    const ScanSourceConfig& c, const std::vector<std::string>& names, bool labels = false) {
  std::vector<std::shared_ptr<const io::KittiSequence>> seqs;
  for (const auto& n : names) {
    const std::string folder = sequenceFolder(c, n);
    std::string poses;
    if (labels && !c.pose_labels.empty()) {
      poses = (fs::path(folder) / c.pose_labels).string();
      if (!fs::is_regular_file(poses))
        throw IoError(poses + ": pose labels (data.pose_labels) not found; write them with "
                              "obm-map --input " + folder + " and copy its trajectory_kitti.txt");
    }
    auto s = std::make_shared<const io::KittiSequence>(folder, poses);
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
  if (c.ground_band > 0.0) scan = removeGround(scan, c.ground_band, i + 1);
  return scan;
}

constexpr double kPi = 3.14159265358979323846;

/// The pair (source = scan j, target = scan i): T_target_source = T_world_i⁻¹ · T_world_j. With
/// `yaw_deg` ≠ 0 the source scan is first turned by Rz(yaw) about its sensor (T becomes T·Rz⁻¹).
obmnet::RegistrationPair makePairIJ(const io::KittiSequence& s, std::size_t i, std::size_t j,
                                    const ScanSourceConfig& c, int num_points,
                                    std::mt19937_64& rng, double yaw_deg = 0.0) {
  Isometry3d T = Isometry3d::Identity();
  if (s.hasGroundTruth()) {
    const auto& gt = s.groundTruthLidar();
    T = gt[i].inverse() * gt[j];
  }
  PointCloud source = loadScan(s, j, c);
  const bool labelled = !c.pose_labels.empty() && s.hasGroundTruth() &&
                        fs::path(s.groundTruthPath()).filename() == c.pose_labels;
  if (labelled && c.label_yaw_hypotheses > 0) {
    // Inference turns the source by H yaw hypotheses 360°/H apart and keeps the best fit, so the
    // network meets residual headings within ±180°/H. Turning the source by the hypothesis
    // nearest to the label's heading trains it on that distribution, not on headings it is
    // never asked to resolve (the label is the mapping app's estimate, not ground truth).
    const double step = 2.0 * kPi / c.label_yaw_hypotheses;
    // Heading of the label once the augmentation has turned the source (gravity-aligned: yaws
    // subtract).
    const double yaw = wrapAngle(std::atan2(T.linear()(1, 0), T.linear()(0, 0)) - yaw_deg * kPi / 180.0);
    yaw_deg += std::round(yaw / step) * step * 180.0 / kPi;
  }
  if (yaw_deg != 0.0) {
    Isometry3d Rz = Isometry3d::Identity();
    Rz.linear() = Eigen::AngleAxisd(yaw_deg * kPi / 180.0, Eigen::Vector3d::UnitZ()).toRotationMatrix();
    source.transform(Rz);
    T = T * Rz.inverse();
  }
  auto pair = obmnet::makeScanPair(source, loadScan(s, i, c), T, c.voxel, num_points, rng,
                                   c.voxel_keypoints, c.surface_points);
  pair.name = s.name() + ":" + std::to_string(j) + "->" + std::to_string(i);
  if (labelled) {
    // A training sequence opened on its pose labels (openAll): T is the label, not ground truth.
    pair.has_pose_label = true;
    pair.T_target_source_label = T;
  }
  return pair;
}

/// The pair (source = scan i + gap, target = scan i).
obmnet::RegistrationPair makePairAt(const io::KittiSequence& s, std::size_t i,
                                    const ScanSourceConfig& c, int num_points,
                                    std::mt19937_64& rng) {
  return makePairIJ(s, i, i + static_cast<std::size_t>(c.frame_gap), c, num_points, rng);
}

/// A revisit: sweeps i < j, j − i ≥ loop_min_separation, within loop_max_distance horizontally.
struct LoopCandidate {
  std::uint32_t i = 0, j = 0;
  double yaw_deg = 0.0;  ///< |yaw| of T_i_j, in [0, 180]
};

/// Every revisit of a sequence with poses (none without): O(n²) over the sweeps' positions.
std::vector<LoopCandidate> findLoops(const io::KittiSequence& s, const ScanSourceConfig& c) {
  std::vector<LoopCandidate> out;
  if (!s.hasGroundTruth()) return out;
  const auto& gt = s.groundTruthLidar();
  const double d2 = c.loop_max_distance * c.loop_max_distance;
  const auto sep = static_cast<std::size_t>(c.loop_min_separation);
  for (std::size_t i = 0; i < gt.size(); ++i)
    for (std::size_t j = i + sep; j < gt.size(); ++j) {
      const Eigen::Vector3d d = gt[j].translation() - gt[i].translation();
      if (d.head<2>().squaredNorm() > d2) continue;
      const Eigen::Matrix3d R = gt[i].linear().transpose() * gt[j].linear();
      const double yaw = std::abs(std::atan2(R(1, 0), R(0, 0))) * 180.0 / kPi;
      out.push_back({static_cast<std::uint32_t>(i), static_cast<std::uint32_t>(j), yaw});
    }
  return out;
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
  auto seqs = openAll(config, config.sequences, /*labels=*/true);
  const std::vector<int> gaps =
      config.frame_gaps.empty() ? std::vector<int>{config.frame_gap} : config.frame_gaps;
  const int max_gap = *std::max_element(gaps.begin(), gaps.end());
  std::vector<double> counts;
  std::vector<std::vector<LoopCandidate>> loops;
  std::size_t total = 0, total_loops = 0;
  for (const auto& s : seqs) {
    if (s->size() <= static_cast<std::size_t>(max_gap))
      throw FormatError(s->directory(), 0,
                        "sequence has " + std::to_string(s->size()) +
                            " scans, not more than the largest frame gap " +
                            std::to_string(max_gap));
    const std::size_t n = s->size() - static_cast<std::size_t>(max_gap);
    counts.push_back(static_cast<double>(n));
    total += n;
    loops.push_back(config.loop_fraction > 0.0 ? findLoops(*s, config)
                                               : std::vector<LoopCandidate>{});
    total_loops += loops.back().size();
  }
  if (config.loop_fraction > 0.0 && total_loops == 0)
    throw ConfigError("data.loop_fraction > 0 but no training sequence has a revisit within " +
                      std::to_string(config.loop_max_distance) +
                      " m (loops are found from each sequence's poses.txt)");
  std::string gap_list;
  for (int g : gaps) gap_list += (gap_list.empty() ? "" : ", ") + std::to_string(g);
  OBM_LOG_INFO("obm-train", "scan pairs: " << seqs.size() << " training sequence(s), " << total
                                           << " sweeps, gaps {" << gap_list << "}, "
                                           << total_loops << " loop pairs (share "
                                           << config.loop_fraction << "), yaw augmentation ±"
                                           << config.yaw_augment_deg << "°");
  auto shared_loops = std::make_shared<const std::vector<std::vector<LoopCandidate>>>(std::move(loops));
  return [seqs, counts, config, num_points, curriculum_epochs, gaps, max_gap,
          shared_loops](std::mt19937_64& rng, int epoch) {
    std::uniform_real_distribution<double> u01(0.0, 1.0);
    std::discrete_distribution<std::size_t> pick(counts.begin(), counts.end());
    const std::size_t si = pick(rng);
    const auto& s = *seqs[si];
    std::uniform_int_distribution<std::size_t> at(0, s.size() - 1 - static_cast<std::size_t>(max_gap));
    const std::size_t i = at(rng);
    if (curriculum_epochs > 0 && epoch <= curriculum_epochs) {
      const double p_self = 1.0 - static_cast<double>(epoch - 1) / curriculum_epochs;
      if (u01(rng) < p_self) return makeSelfPair(s, i, config, num_points, rng);
    }
    const double yaw = config.yaw_augment_deg > 0.0
                           ? std::uniform_real_distribution<double>(-config.yaw_augment_deg,
                                                                    config.yaw_augment_deg)(rng)
                           : 0.0;
    const auto& lp = (*shared_loops)[si];
    if (!lp.empty() && u01(rng) < config.loop_fraction) {
      const auto& l = lp[std::uniform_int_distribution<std::size_t>(0, lp.size() - 1)(rng)];
      // Either sweep may be the source.
      if (u01(rng) < 0.5) return makePairIJ(s, l.i, l.j, config, num_points, rng, yaw);
      return makePairIJ(s, l.j, l.i, config, num_points, rng, yaw);
    }
    const int gap = gaps[std::uniform_int_distribution<std::size_t>(0, gaps.size() - 1)(rng)];
    return makePairIJ(s, i, i + static_cast<std::size_t>(gap), config, num_points, rng, yaw);
  };
}

ScanPairClass ScanPairClass::parse(const std::string& s) {
  ScanPairClass c;
  if (s == "loop" || s == "loops") {
    c.loop = true;
    return c;
  }
  std::string digits = (!s.empty() && (s[0] == 'k' || s[0] == 'K')) ? s.substr(1) : s;
  try {
    std::size_t used = 0;
    c.gap = std::stoi(digits, &used);
    if (used != digits.size() || c.gap < 1) throw std::invalid_argument(s);
  } catch (const std::exception&) {
    throw ConfigError("pair class '" + s + "': expected a frame gap (k10 or 10) or 'loop'");
  }
  return c;
}

std::vector<obmnet::RegistrationPair> scanPairs(const ScanSourceConfig& config,
                                                const std::vector<std::string>& sequences,
                                                const ScanPairClass& cls, int num_points, int n,
                                                std::uint64_t seed) {
  std::vector<obmnet::RegistrationPair> pairs;
  if (sequences.empty() || n <= 0) return pairs;
  ScanSourceConfig c = config;
  c.frame_gap = cls.loop ? 1 : cls.gap;
  const auto seqs = openAll(c, sequences);
  for (const auto& s : seqs)
    if (!s->hasGroundTruth())
      throw IoError(s->directory() +
                    ": sequence without ground truth (poses.txt) cannot be scored");
  std::mt19937_64 rng(seed);
  if (!cls.loop) {
    const int per = (n + static_cast<int>(seqs.size()) - 1) / static_cast<int>(seqs.size());
    for (const auto& s : seqs) {
      const std::size_t last = s->size() - 1 - static_cast<std::size_t>(c.frame_gap);
      for (int k = 0; k < per && static_cast<int>(pairs.size()) < n; ++k) {
        // Evenly spaced along the sequence, so the pairs cover all of it.
        const std::size_t i =
            per > 1 ? (last * static_cast<std::size_t>(k)) / static_cast<std::size_t>(per - 1) : 0;
        pairs.push_back(makePairAt(*s, i, c, num_points, rng));
      }
    }
    return pairs;
  }
  // Loops: every revisit of every sequence, binned by yaw difference (6 bins of 30°); the pairs
  // are drawn round-robin over the bins, each bin's candidates taken evenly along its list, so
  // same-direction, crossing and opposite-direction revisits are all represented.
  std::vector<std::vector<std::pair<std::size_t, LoopCandidate>>> bins(6);
  for (std::size_t si = 0; si < seqs.size(); ++si)
    for (const auto& l : findLoops(*seqs[si], c))
      bins[std::min<std::size_t>(5, static_cast<std::size_t>(l.yaw_deg / 30.0))].push_back({si, l});
  std::size_t total = 0;
  for (const auto& b : bins) total += b.size();
  if (total == 0)
    throw Error("no loop pair (a revisit within " + std::to_string(c.loop_max_distance) +
                " m, at least " + std::to_string(c.loop_min_separation) +
                " sweeps apart) in the given sequences");
  std::vector<std::size_t> quota(6, 0);
  for (int k = 0, given = 0; given < n && given < static_cast<int>(total); ++k) {
    auto& b = bins[static_cast<std::size_t>(k % 6)];
    if (quota[static_cast<std::size_t>(k % 6)] < b.size()) {
      ++quota[static_cast<std::size_t>(k % 6)];
      ++given;
    }
  }
  for (std::size_t b = 0; b < 6; ++b)
    for (std::size_t q = 0; q < quota[b]; ++q) {
      const auto& [si, l] = bins[b][(q * bins[b].size()) / quota[b]];
      pairs.push_back(makePairIJ(*seqs[si], l.i, l.j, c, num_points, rng));
      pairs.back().name += " (loop, yaw " + std::to_string(static_cast<int>(std::lround(l.yaw_deg))) + "°)";
    }
  return pairs;
}

std::vector<obmnet::RegistrationPair> scanValidationPairs(const ScanSourceConfig& config,
                                                          int num_points, int n,
                                                          std::uint64_t seed) {
  if (config.val_sequences.empty() || n <= 0) return {};
  // One share per pair class the training draws: every gap of frame_gaps (or frame_gap) and,
  // when the training has loops, the loop pairs; model selection then sees all of them.
  std::vector<ScanPairClass> classes;
  for (int g : config.frame_gaps.empty() ? std::vector<int>{config.frame_gap} : config.frame_gaps)
    classes.push_back({g, false});
  if (config.loop_fraction > 0.0) classes.push_back({0, true});
  std::vector<obmnet::RegistrationPair> pairs;
  const int k = static_cast<int>(classes.size());
  for (int c = 0; c < k; ++c) {
    const int share = n / k + (c < n % k ? 1 : 0);
    auto part = scanPairs(config, config.val_sequences, classes[static_cast<std::size_t>(c)],
                          num_points, share, seed + static_cast<std::uint64_t>(c));
    for (auto& p : part) pairs.push_back(std::move(p));
  }
  return pairs;
}

}  // namespace obm::datasets
