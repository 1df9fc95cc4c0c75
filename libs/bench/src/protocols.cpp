#include "obm/bench/protocols.hpp"

#include <algorithm>
#include <cstdio>
#include <random>
#include <sstream>

#include "obm/bench/scoring.hpp"
#include "obm/config/config_node.hpp"
#include "obm/core/errors.hpp"
#include "obm/datasets/fragment_source.hpp"
#include "obm/datasets/object_source.hpp"
#include "obm/datasets/scan_source.hpp"

namespace obm::bench {
namespace {

/// Two different depth frames of an RGB-D sequence, each in its own camera frame, in metres,
/// with their colours (the coloured ICP rows use them; every other method sees geometry).
PairSet rgbdFrames(const PairRequest& r) {
  const auto root = ConfigNode::loadFile(r.data_config);
  const auto data = root.child("data");
  std::string dir;
  data.get("dir", dir);
  const auto opts = datasets::RgbdFragmentOptions::load(data.child("rgbd"));
  if (r.group != "val" && r.group != "unseen")
    throw ConfigError("--protocol rgbd_frames: --group must be val or unseen, not '" + r.group +
                      "'");
  const auto& seqs = r.group == "val" ? opts.val_sequences : opts.test_sequences;
  int lo = 5, hi = 30;
  char tail = 0;
  if (std::sscanf(r.frame_gaps.c_str(), "%d:%d%c", &lo, &hi, &tail) != 2 || lo < 1 || hi < lo)
    throw ConfigError("--frame-gaps: expected MIN:MAX with 1 <= MIN <= MAX, got '" +
                      r.frame_gaps + "'");
  PairSet out;
  out.pairs = datasets::rgbdFramePairs(dir, opts, seqs, lo, hi, r.n_pairs, r.seed, true);
  std::ostringstream os;
  os << "protocol rgbd_frames (frames i, i+s, s in [" << lo << ", " << hi << "]), "
     << out.pairs.size() << " pairs of the " << r.group << " sequences of " << r.data_config
     << ", voxel " << opts.voxel << " m, seed " << r.seed;
  out.info = os.str();
  return out;
}

/// RIENet's KITTI protocol: pairs (i, i + k) of sweeps, each voxelised and sampled to the
/// config's points, scored against the sequences' ground truth; or revisits (loops).
PairSet kittiSweeps(const PairRequest& r) {
  const auto root = ConfigNode::loadFile(r.data_config);
  auto scans = datasets::ScanSourceConfig::load(root.child("data"));
  // Every method sees whole sweeps: a model trained without the road cuts it itself
  // (model.ground_band, recorded in the model file).
  scans.ground_band = 0.0;
  if (!r.sequences.empty()) {
    scans.val_sequences = r.sequences;
  } else if (r.group != "val") {
    throw ConfigError("--protocol kitti: give the test sequences with --sequence DIR (the "
                      "config's val_sequences are used only with --group val)");
  }
  int scan_points = 1024;
  root.child("train").child("pairs").get("num_points", scan_points);
  const auto cls = r.pair_class.empty() ? datasets::ScanPairClass{scans.frame_gap, false}
                                        : datasets::ScanPairClass::parse(r.pair_class);
  PairSet out;
  out.pairs = datasets::scanPairs(scans, scans.val_sequences, cls, scan_points, r.n_pairs, r.seed);
  std::string names;
  for (const auto& q : scans.val_sequences) names += (names.empty() ? "" : ", ") + q;
  std::ostringstream os;
  os << "protocol kitti "
     << (cls.loop ? std::string("loop pairs (revisits)") : "(i, i+" + std::to_string(cls.gap) + ")")
     << ", " << out.pairs.size() << " pairs of " << names << ", " << scan_points
     << " points per sweep after a " << scans.voxel << " m voxel grid, seed " << r.seed;
  out.info = os.str();
  return out;
}

/// Object and fragment pairs (RIENet's protocols): each pair cut from one object of the group.
PairSet objectPairs(const PairRequest& r) {
  const auto root = ConfigNode::loadFile(r.data_config);
  auto proto = obmnet::PairProtocol::preset(toString(r.protocol));
  auto source_cfg = datasets::ObjectSourceConfig::load(root.child("data"));
  // Independent samplings draw source and target from disjoint halves of every surface sample of
  // the object, so the whole sample is kept.
  if (proto.resample && source_cfg.source != "modelnet40" && source_cfg.source != "rgbd")
    source_cfg.objects.keep_points = source_cfg.objects.surface_points;
  // Dense reference samples of every mesh for the surface error (8192: the floor of a symmetry
  // stays below 0.001 on a box, docs/metrics.md); the pairs do not change.
  if (r.surface_references) source_cfg.objects.reference_points = 8192;
  auto set = datasets::loadObjectSet(source_cfg);
  if (r.group != "seen" && r.group != "val" && r.group != "unseen")
    throw ConfigError("--group must be seen, val or unseen, not '" + r.group + "'");
  const auto& objects = r.group == "seen" ? set.train : r.group == "val" ? set.val : set.test;
  const auto& references = r.group == "seen"  ? set.train_reference
                           : r.group == "val" ? set.val_reference
                                              : set.test_reference;
  if (objects.empty()) throw Error("no objects in the " + r.group + " group of " + r.data_config);
  PairSet out;
  // Mesh sources have reference samples; ModelNet40's point sets and RGB-D fragments not.
  if (references.size() == objects.size()) {
    const auto used = std::min(objects.size(), static_cast<std::size_t>(r.n_pairs));
    for (std::size_t o = 0; o < used; ++o)
      out.scorers.push_back(std::make_unique<eval::SurfaceErrorScorer>(references[o]));
    for (int i = 0; i < r.n_pairs; ++i)
      out.scorer_of_pair.push_back(
          out.scorers[static_cast<std::size_t>(i) % objects.size()].get());
  }
  std::mt19937_64 rng(r.seed);
  for (int i = 0; i < r.n_pairs; ++i) {
    const auto& object = objects[static_cast<std::size_t>(i) % objects.size()];
    out.pairs.push_back(obmnet::makePair(object, proto, rng));
    out.pairs.back().name = object.frame_id;
  }
  double ov = 0;
  for (const auto& p : out.pairs) ov += p.overlap / static_cast<double>(out.pairs.size());
  std::ostringstream os;
  os << "protocol " << toString(r.protocol) << ", " << r.group << " group (" << objects.size()
     << " objects), " << r.n_pairs << " pairs, seed " << r.seed << ", mean overlap " << ov;
  out.info = os.str();
  return out;
}

}  // namespace

PairSet makePairs(const PairRequest& r) {
  if (r.protocol == Protocol::Pairs) {
    PairSet out;
    out.pairs = readPairFolder(r.pairs_dir);
    out.info = "pairs from " + r.pairs_dir;
    return out;
  }
  if (r.data_config.empty())
    throw ConfigError(std::string("--protocol ") + toString(r.protocol) +
                      ": no data config (the preset's benchmark.data_config, or --config)");
  if (r.protocol == Protocol::RgbdFrames) return rgbdFrames(r);
  if (r.protocol == Protocol::Kitti) return kittiSweeps(r);
  return objectPairs(r);
}

void startNear(std::vector<obmnet::RegistrationPair>& pairs, const std::string& deg_m,
               std::uint64_t seed) {
  double deg = -1.0, m = -1.0;
  char tail = 0;
  if (std::sscanf(deg_m.c_str(), "%lf,%lf%c", &deg, &m, &tail) != 2 || !(deg >= 0.0) ||
      !(deg <= 180.0) || !(m >= 0.0))
    throw ConfigError("--start-near: expected DEG,M with 0 <= DEG <= 180 and M >= 0, got '" +
                      deg_m + "'");
  std::mt19937_64 rng(seed);
  for (auto& p : pairs) datasets::startNearPose(p, p.T_target_source, deg, m, rng);
}

}  // namespace obm::bench
