#include "obm/datasets/fragment_source.hpp"

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <memory>
#include <random>
#include <tuple>

#include "obm/config/config_node.hpp"
#include "obm/core/cloud_ops.hpp"
#include "obm/core/errors.hpp"
#include "obm/core/log.hpp"
#include "obm/core/mesh.hpp"
#include "obm/io/rgbd.hpp"

namespace fs = std::filesystem;

namespace obm::datasets {

RgbdFragmentOptions RgbdFragmentOptions::load(const ConfigNode& node) {
  RgbdFragmentOptions o;
  node.checkKeys({"layout", "train_sequences", "val_sequences", "test_sequences",
                  "fragment_frames", "frame_step", "test_frame_step", "stride", "min_depth", "max_depth", "voxel",
                  "radius", "pair_gaps", "pose_labels", "start_near_label"});
  node.get("layout", o.layout);
  try {
    io::parseRgbdLayout(o.layout);
  } catch (const ConfigError& e) {
    throw ConfigError(node.where("layout") + ": " + e.what());
  }
  node.get("train_sequences", o.train_sequences);
  node.get("val_sequences", o.val_sequences);
  node.get("test_sequences", o.test_sequences);
  node.get("fragment_frames", o.fragment_frames);
  node.get("frame_step", o.frame_step);
  o.test_frame_step = o.frame_step;
  node.get("test_frame_step", o.test_frame_step);
  node.get("stride", o.stride);
  node.get("min_depth", o.min_depth);
  node.get("max_depth", o.max_depth);
  node.get("voxel", o.voxel);
  node.get("radius", o.radius);
  node.get("pair_gaps", o.pair_gaps);
  node.get("pose_labels", o.pose_labels);
  node.get("start_near_label", o.start_near_label);
  if (!o.start_near_label.empty()) {
    if (o.start_near_label.size() != 2 || !(o.start_near_label[0] >= 0.0) ||
        !(o.start_near_label[0] <= 180.0) || !(o.start_near_label[1] >= 0.0))
      throw ConfigError(node.where("start_near_label") +
                        ": expected [MAX_DEG, MAX_M] with 0 <= MAX_DEG <= 180 and MAX_M >= 0");
    if (o.pose_labels.empty())
      throw ConfigError(node.where("start_near_label") +
                        ": training pairs start near their pose label; set pose_labels too");
  }
  if (o.pose_labels.find('/') != std::string::npos)
    throw ConfigError(node.where("pose_labels") + ": '" + o.pose_labels +
                      "' is a file name inside each training sequence folder, not a path");
  if (!o.pose_labels.empty() && o.pair_gaps.empty())
    throw ConfigError(node.where("pose_labels") +
                      ": pose labels train frame pairs only; set pair_gaps too");
  if (!o.pair_gaps.empty() &&
      (o.pair_gaps.size() != 2 || o.pair_gaps[0] < 1 || o.pair_gaps[1] < o.pair_gaps[0]))
    throw ConfigError(node.where("pair_gaps") + ": expected [MIN, MAX] with 1 <= MIN <= MAX");
  if (o.train_sequences.empty())
    throw ConfigError(node.where("train_sequences") + ": no training sequence");
  if (o.fragment_frames < 1) throw ConfigError(node.where("fragment_frames") + ": must be >= 1");
  if (o.frame_step < 1) throw ConfigError(node.where("frame_step") + ": must be >= 1");
  if (o.test_frame_step < 1)
    throw ConfigError(node.where("test_frame_step") + ": must be >= 1");
  if (o.stride < 1) throw ConfigError(node.where("stride") + ": must be >= 1");
  if (!(o.min_depth >= 0.0) || !(o.max_depth > o.min_depth))
    throw ConfigError(node.where("max_depth") + ": need 0 <= min_depth < max_depth");
  if (!(o.voxel >= 0.0)) throw ConfigError(node.where("voxel") + ": must be >= 0");
  if (!(o.radius > 0.0)) throw ConfigError(node.where("radius") + ": must be > 0");
  return o;
}

namespace {

/// A sequence entry "[LAYOUT:]PATH": the layout prefix overrides the default layout.
std::pair<io::RgbdLayout, std::string> splitLayout(const std::string& entry,
                                                   const std::string& default_layout) {
  const auto colon = entry.find(':');
  if (colon != std::string::npos && colon > 0 && entry.find('/') > colon) {
    const std::string prefix = entry.substr(0, colon);
    try {
      return {io::parseRgbdLayout(prefix), entry.substr(colon + 1)};
    } catch (const ConfigError&) {
      // not a layout: a path with a colon
    }
  }
  return {io::parseRgbdLayout(default_layout), entry};
}

/// A sequence path: `$VAR/rest` or `${VAR}/rest` takes the environment variable (e.g.
/// $OBM_SHARED_DATA for the real test data), an absolute path is kept, others are under `dir`.
std::string resolve(const std::string& dir, const std::string& name) {
  if (!name.empty() && name[0] == '$') {
    const bool braced = name.size() > 1 && name[1] == '{';
    const std::size_t end = braced ? name.find('}') : name.find('/');
    const std::string var =
        braced ? name.substr(2, end == std::string::npos ? std::string::npos : end - 2)
               : name.substr(1, end == std::string::npos ? std::string::npos : end - 1);
    const char* value = std::getenv(var.c_str());
    if (value == nullptr || *value == '\0')
      throw ConfigError("sequence '" + name + "': environment variable " + var + " is not set");
    const std::size_t rest = braced ? (end == std::string::npos ? name.size() : end + 1)
                                    : (end == std::string::npos ? name.size() : end);
    return std::string(value) + name.substr(rest);
  }
  if (fs::path(name).is_absolute() || dir.empty()) return name;
  return (fs::path(dir) / name).string();
}

/// Opens the sequence of a list entry "[LAYOUT:]PATH" (`path` receives the resolved folder).
io::RgbdSequence openEntry(const std::string& dir, const std::string& entry,
                           const std::string& default_layout, std::string& path,
                           const std::string& pose_labels = "") {
  const auto [layout, rel] = splitLayout(entry, default_layout);
  path = resolve(dir, rel);
  if (!fs::is_directory(path)) throw IoError(path + ": RGB-D sequence folder not found");
  io::RgbdSequenceOptions so;
  if (!pose_labels.empty()) {
    // The labels take the place of the ground truth: the mapping app's trajectory of this
    // sequence, associated with the depth frames by time stamp as a ground-truth file would be.
    so.groundtruth_path = (fs::path(path) / pose_labels).string();
    if (!fs::is_regular_file(so.groundtruth_path))
      throw IoError(so.groundtruth_path +
                    ": pose labels (data.rgbd.pose_labels) not found; write them with "
                    "scripts/make_indoor_training_data.sh OUT_DIR BUILD_DIR labels");
  }
  return io::RgbdSequence::open(path, layout, so);
}

/// Fragments of one sequence, appended to `out`.
void addFragments(const std::string& dir, const std::string& entry, const RgbdFragmentOptions& o,
                  int frame_step, int keep_points, std::uint64_t seed,
                  std::vector<PointCloud>& out) {
  std::string path;
  const auto seq = openEntry(dir, entry, o.layout, path);
  const std::string name = fs::path(path).filename().string();
  const auto n_frames = static_cast<int>(seq.size());
  int made = 0, skipped = 0;
  for (int first = 0; first + o.fragment_frames <= n_frames; first += frame_step) {
    const auto& f0 = seq.frame(static_cast<std::size_t>(first));
    PointCloud fused;
    fused.frame_id = "camera";
    for (int k = 0; k < o.fragment_frames; ++k) {
      const auto i = static_cast<std::size_t>(first + k);
      PointCloud c = seq.cloud(i, o.min_depth, o.max_depth, o.stride);
      if (k > 0) {
        const auto& fk = seq.frame(i);
        if (!f0.has_pose || !fk.has_pose)
          throw FormatError(path, 0,
                            "frame " + std::to_string(i) +
                                " has no ground-truth pose: fusing fragment_frames > 1 needs one");
        // Fused in the fragment's first camera frame: T_first_k = T_world_first⁻¹ · T_world_k.
        c.transform(f0.T_world_camera.inverse() * fk.T_world_camera);
      }
      fused.points.insert(fused.points.end(), c.points.begin(), c.points.end());
    }
    PointCloud v = o.voxel > 0.0 ? voxelDownsample(fused, o.voxel) : fused;
    if (v.size() < static_cast<std::size_t>(keep_points)) {
      ++skipped;
      continue;
    }
    // The sample depends on the sequence, the frame and the seed only, not on the load order.
    std::mt19937_64 rng(seed ^ (std::hash<std::string>{}(name) + 0x9e3779b97f4a7c15ull *
                                                                   static_cast<std::uint64_t>(first)));
    PointCloud frag = randomSubset(v, static_cast<std::size_t>(keep_points), rng);
    frag.intensity.clear();
    frag.colors.clear();
    // RIENet's 7Scenes normalisation: centred, max|v| = radius (a fragment whose points all
    // coincide cannot be scaled and is skipped).
    normalizeToSphere(frag, static_cast<float>(o.radius));
    if (std::all_of(frag.points.begin(), frag.points.end(),
                    [](const Eigen::Vector3f& p) { return p.isZero(); })) {
      ++skipped;
      continue;
    }
    frag.frame_id = name + ":" + std::to_string(first);
    out.push_back(std::move(frag));
    ++made;
  }
  if (skipped > 0)
    OBM_LOG_WARN("fragments", path << ": " << skipped << " fragment(s) with fewer than "
                                   << keep_points << " points after the " << o.voxel
                                   << " m voxel grid skipped");
  OBM_LOG_INFO("fragments", path << ": " << made << " fragments of " << o.fragment_frames
                                 << " frame(s), every " << frame_step << " of " << n_frames);
}

}  // namespace

obmnet::ObjectSet loadRgbdFragments(const std::string& dir, const RgbdFragmentOptions& options,
                                    int keep_points, std::uint64_t seed) {
  obmnet::ObjectSet set;
  for (const auto& s : options.train_sequences)
    addFragments(dir, s, options, options.frame_step, keep_points, seed, set.train);
  for (const auto& s : options.val_sequences)
    addFragments(dir, s, options, options.frame_step, keep_points, seed, set.val);
  for (const auto& s : options.test_sequences)
    addFragments(dir, s, options, options.test_frame_step, keep_points, seed, set.test);
  if (set.train.empty())
    throw IoError((dir.empty() ? std::string(".") : dir) +
                  ": no training fragment with " + std::to_string(keep_points) + " points");
  return set;
}

namespace {

/// Frame i back-projected with the options' stride and depth range, on their voxel grid, in
/// metres in its camera frame; geometry only, or with the pixels' colours (`with_colors`, when
/// the frame has a colour image).
PointCloud frameGeometry(const io::RgbdSequence& seq, int i, const RgbdFragmentOptions& o,
                         bool with_colors = false) {
  const auto f = static_cast<std::size_t>(i);
  const bool colour = with_colors && !seq.frame(f).color_path.empty();
  PointCloud c = seq.cloud(f, o.min_depth, o.max_depth, o.stride, colour);
  if (o.voxel > 0.0) c = voxelDownsample(c, o.voxel);
  c.intensity.clear();
  if (!colour) c.colors.clear();
  return c;
}

/// Exactly n points: a random subset, or all points plus random repeats when there are fewer.
PointCloud exactlyN(const PointCloud& c, std::size_t n, std::mt19937_64& rng) {
  PointCloud out = randomSubset(c, n, rng);
  if (out.size() >= n || c.empty()) return out;
  std::uniform_int_distribution<std::size_t> any(0, c.size() - 1);
  while (out.size() < n) out.points.push_back(c.points[any(rng)]);
  return out;
}

}  // namespace

std::vector<obmnet::RegistrationPair> rgbdFramePairs(const std::string& dir,
                                                     const RgbdFragmentOptions& options,
                                                     const std::vector<std::string>& sequences,
                                                     int min_gap, int max_gap, int n,
                                                     std::uint64_t seed, bool with_colors) {
  if (min_gap < 1 || max_gap < min_gap)
    throw ConfigError("RGB-D frame pairs: need 1 <= min_gap <= max_gap, got " +
                      std::to_string(min_gap) + ".." + std::to_string(max_gap));
  std::vector<obmnet::RegistrationPair> pairs;
  if (sequences.empty() || n <= 0) return pairs;
  std::mt19937_64 rng(seed);
  const int per = (n + static_cast<int>(sequences.size()) - 1) / static_cast<int>(sequences.size());
  for (const auto& entry : sequences) {
    std::string path;
    const auto seq = openEntry(dir, entry, options.layout, path);
    const std::string name = fs::path(path).filename().string();
    const int frames = static_cast<int>(seq.size());
    if (frames < 2) throw FormatError(path, 0, "an RGB-D pair needs at least 2 frames");
    auto frameCloud = [&](int i) { return frameGeometry(seq, i, options, with_colors); };
    // A sequence too short for the gaps (e.g. a few real frames) gives each of its pairs once.
    std::vector<std::pair<int, int>> all;
    if (frames - 1 < min_gap)
      for (int a = 0; a < frames; ++a)
        for (int b = a + 1; b < frames; ++b) all.emplace_back(a, b);
    const int count = all.empty() ? per : std::min(per, static_cast<int>(all.size()));
    for (int k = 0; k < count && static_cast<int>(pairs.size()) < n; ++k) {
      int i = 0, j = 0;
      if (!all.empty()) {
        std::tie(i, j) = all[static_cast<std::size_t>(k)];
      } else {
        // The gap first, then the first frame evenly along what the gap leaves.
        const int gap = std::uniform_int_distribution<int>(min_gap, std::min(max_gap, frames - 1))(rng);
        const int last = frames - 1 - gap;
        i = per > 1 ? (last * k) / (per - 1) : 0;
        j = i + gap;
      }
      const auto& fi = seq.frame(static_cast<std::size_t>(i));
      const auto& fj = seq.frame(static_cast<std::size_t>(j));
      if (!fi.has_pose || !fj.has_pose)
        throw FormatError(path, 0,
                          "frames " + std::to_string(i) + " and " + std::to_string(j) +
                              " need ground-truth poses to be scored");
      obmnet::RegistrationPair p;
      p.source = frameCloud(j);
      p.target = frameCloud(i);
      p.source.frame_id = "camera_" + std::to_string(j);
      p.target.frame_id = "camera_" + std::to_string(i);
      p.T_target_source = fi.T_world_camera.inverse() * fj.T_world_camera;
      p.overlap = -1.0;
      p.name = name + ":" + std::to_string(j) + "->" + std::to_string(i);
      pairs.push_back(std::move(p));
    }
  }
  return pairs;
}

obmnet::PairSampler rgbdFramePairSampler(const std::string& dir,
                                         const RgbdFragmentOptions& options, int num_points) {
  if (options.pair_gaps.size() != 2)
    throw ConfigError("data.rgbd.pair_gaps: expected [MIN, MAX] for RGB-D frame pairs");
  const int min_gap = options.pair_gaps[0], max_gap = options.pair_gaps[1];
  auto seqs = std::make_shared<std::vector<io::RgbdSequence>>();
  std::vector<std::string> names;
  std::vector<double> weights;
  for (const auto& entry : options.train_sequences) {
    std::string path;
    io::RgbdSequence seq = openEntry(dir, entry, options.layout, path, options.pose_labels);
    if (!options.pose_labels.empty()) {
      std::size_t posed = 0;
      for (std::size_t f = 0; f < seq.size(); ++f) posed += seq.frame(f).has_pose ? 1 : 0;
      if (posed < seq.size())
        OBM_LOG_WARN("obm-train", path << ": " << seq.size() - posed << " of " << seq.size()
                                       << " frames have no pose label; their pairs are skipped");
    }
    if (seq.size() <= static_cast<std::size_t>(min_gap))
      throw FormatError(path, 0,
                        "sequence has " + std::to_string(seq.size()) +
                            " frames, not more than the smallest pair gap " +
                            std::to_string(min_gap));
    weights.push_back(static_cast<double>(seq.size()));
    names.push_back(fs::path(path).filename().string());
    seqs->push_back(std::move(seq));
  }
  OBM_LOG_INFO("obm-train", "RGB-D frame pairs: " << seqs->size() << " training sequence(s), gaps "
                                                  << min_gap << "-" << max_gap << " frames, "
                                                  << num_points << " points per frame");
  const auto n = static_cast<std::size_t>(num_points);
  return [seqs, names, weights, options, min_gap, max_gap, n](std::mt19937_64& rng, int) {
    std::discrete_distribution<std::size_t> pick(weights.begin(), weights.end());
    const std::size_t si = pick(rng);
    const io::RgbdSequence& seq = (*seqs)[si];
    const int frames = static_cast<int>(seq.size());
    const bool labelled = !options.pose_labels.empty();
    int i = 0, j = 0;
    // With labels, a pair of two labelled frames (frames the mapping app lost carry none).
    for (int attempt = 0; attempt < 64; ++attempt) {
      const int gap =
          std::uniform_int_distribution<int>(min_gap, std::min(max_gap, frames - 1))(rng);
      i = std::uniform_int_distribution<int>(0, frames - 1 - gap)(rng);
      j = i + gap;
      if (!labelled || (seq.frame(static_cast<std::size_t>(i)).has_pose &&
                        seq.frame(static_cast<std::size_t>(j)).has_pose))
        break;
    }
    auto frameCloud = [&](int f) {
      PointCloud out = exactlyN(frameGeometry(seq, f, options), n, rng);
      out.frame_id = "camera_" + std::to_string(f);
      return out;
    };
    obmnet::RegistrationPair p;
    p.source = frameCloud(j);
    p.target = frameCloud(i);
    const auto& fi = seq.frame(static_cast<std::size_t>(i));
    const auto& fj = seq.frame(static_cast<std::size_t>(j));
    if (fi.has_pose && fj.has_pose) {
      p.T_target_source = fi.T_world_camera.inverse() * fj.T_world_camera;
      if (labelled) {
        // Opened on its pose labels: the pose is the mapping app's estimate, not ground truth.
        p.has_pose_label = true;
        p.T_target_source_label = p.T_target_source;
      }
    } else if (labelled) {
      throw FormatError(names[si], 0, "no pair of labelled frames found in 64 draws: are the pose "
                                      "labels (data.rgbd.pose_labels) of this sequence nearly empty?");
    }
    p.overlap = -1.0;
    p.name = names[si] + ":" + std::to_string(j) + "->" + std::to_string(i);
    if (!options.start_near_label.empty())
      startNearPose(p, p.T_target_source_label, options.start_near_label[0],
                    options.start_near_label[1], rng);
    return p;
  };
}

void startNearPose(obmnet::RegistrationPair& pair, const Isometry3d& T_near, double max_deg,
                   double max_m, std::mt19937_64& rng) {
  std::normal_distribution<double> g(0.0, 1.0);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  // One draw per statement: the order of a constructor's arguments is unspecified, and the
  // pairs must be the same from every compiler (z, y, x is the order this project's numbers use).
  auto direction = [&] {
    Eigen::Vector3d v = Eigen::Vector3d::Zero();
    while (v.norm() < 1e-9) {
      v.z() = g(rng);
      v.y() = g(rng);
      v.x() = g(rng);
    }
    return Eigen::Vector3d(v.normalized());
  };
  Isometry3d delta = Isometry3d::Identity();
  const double angle = u(rng) * max_deg * M_PI / 180.0;
  delta.linear() = Eigen::AngleAxisd(angle, direction()).toRotationMatrix();
  delta.translation() = u(rng) * max_m * direction();
  // The source lands in A = Δ·T_near: target ≈ T·source = (T·A⁻¹)·(A·source), and with
  // T = T_near the pair's pose becomes Δ⁻¹: its RRE / RTE from not moving are Δ's angle and shift.
  const Isometry3d A = delta * T_near;
  const std::string frame = pair.source.frame_id + "@start";
  pair.source = pair.source.transformed(A, frame);
  pair.T_target_source = pair.T_target_source * A.inverse();
  if (pair.has_pose_label) pair.T_target_source_label = pair.T_target_source_label * A.inverse();
}

std::vector<obmnet::RegistrationPair> withPointCount(std::vector<obmnet::RegistrationPair> pairs,
                                                    int num_points, std::uint64_t seed) {
  std::mt19937_64 rng(seed);
  const auto n = static_cast<std::size_t>(num_points);
  for (auto& p : pairs) {
    const std::string sf = p.source.frame_id, tf = p.target.frame_id;
    p.source = exactlyN(p.source, n, rng);
    p.target = exactlyN(p.target, n, rng);
    p.source.frame_id = sf;
    p.target.frame_id = tf;
  }
  return pairs;
}

}  // namespace obm::datasets
