#pragma once
/// \file preset.hpp
/// A matcher preset: one commented YAML per data kind (config/presets/<kind>.yaml) holding the
/// scan matcher a kind of data is registered with — model, search, the choice among starts, free
/// space, ICP, confidence (obm::registration::ScanMatcherConfig under `matcher:`) — and what the
/// benchmark adds to it (`benchmark:`: its recall, the peers' scale, the rows it lists). obm-bench
/// picks the preset from its protocol or from the pairs themselves; any tool that registers
/// that kind of data can load the same `matcher:` (ScanMatcherConfig::load).
#include <string>
#include <utility>
#include <vector>

#include "obm/obmnet/data.hpp"
#include "obm/registration/factory.hpp"

namespace obm {
class ConfigNode;
}  // namespace obm

namespace obm::bench {

/// The pair sets obm-bench generates (`--protocol`); `Pairs` = a folder of pairs (`--pairs`).
enum class Protocol {
  Clean,         ///< objects, shared samples (RIENet's ModelNet40 protocol)
  Jitter,        ///< ... with Gaussian jitter
  Outliers,      ///< ... with outliers
  Partial,       ///< ... partial crops
  PartialNoise,  ///< ... partial and jittered
  Resampled,     ///< objects, each cloud sampled on its own (no shared sample)
  Indoor,        ///< RGB-D fragments
  Icl,           ///< ICL-NUIM fragments
  RgbdFrames,    ///< two different depth frames of an RGB-D sequence
  Kitti,         ///< LiDAR sweep pairs (i, i + k) and loops
  Pairs,         ///< a folder of pairs
};

/// Parses a protocol name (clean, jitter, outliers, partial, partial_noise, resampled, indoor,
/// icl, rgbd_frames, kitti); throws ConfigError "`where`: unknown protocol ..." listing them.
Protocol parseProtocol(const std::string& name, const std::string& where);
const char* toString(Protocol protocol);
/// The preset of a generated protocol's data kind: objects (clean, partial), objects_noise
/// (jitter, outliers, partial_noise), objects_resampled, fragments (indoor, icl), rgbd_frames,
/// lidar (kitti). ContractError for Protocol::Pairs (see presetForPairs).
std::string presetName(Protocol protocol);

/// What obm-bench adds to a preset's matcher (YAML `benchmark:`).
struct BenchParams {
  /// YAML whose `data:` describes the generated pairs of this kind (relative paths resolved
  /// against the preset's folder); empty for kinds without a generated protocol.
  std::string data_config;
  double recall_deg = 1.0;    ///< a pair is registered when RRE < this [deg] ...
  double recall_trans = 0.1;  ///< ... and RTE < this [the pairs' units]
  /// Length that scales the Open3D peers' distances, which are set for unit-sphere objects
  /// (20 for LiDAR sweeps in metres: a 1 m voxel, 5 m feature radius).
  double open3d_unit = 1.0;
  /// RANSAC samples of the `+ransac` and `+consensus` rows (the network's correspondences).
  int ransac_iterations = 5000;
  /// > 0: the rows with more starts (obmnet+icp-turns, icp-turns, the FGR-start rows) turn the
  /// start by ± this about each of matcher.obmnet.start_turn_axes [deg].
  double start_turn_deg = 0.0;
  /// Every method's pose also scored by its free-space agreement (sensor frames only: the clouds
  /// must be in their sensor's frame), with matcher.obmnet.free_space.
  bool score_free_space = false;
  /// Generated object pairs: also the recall up to the object's symmetries (mean surface
  /// distance below this; 0 = off).
  double surface_error = 0.005;
  /// The rows listed without --methods; `open3d` stands for every Open3D peer of the build.
  std::vector<std::string> rows;

  /// Reads the keys of `node` (unknown keys rejected); resolves data_config against the file.
  static BenchParams load(const ConfigNode& node);
};

/// A preset file: `matcher:` and `benchmark:`.
struct Preset {
  std::string name;  ///< the file's stem (lidar, rgbd_frames, ...)
  std::string file;
  registration::ScanMatcherConfig matcher;
  BenchParams bench;

  /// Loads `file`, first setting the text values `texts` (key path, value: file names, which YAML
  /// need not read back as text), then applying `assignments` (`matcher.icp.kernel_scale=0.2`,
  /// `benchmark.recall_deg=5`: obm-bench's --set). Errors name the file and key.
  static Preset load(const std::string& file, const std::vector<std::string>& assignments = {},
                     const std::vector<std::pair<std::string, std::string>>& texts = {});
};

/// The preset for a folder of pairs of unknown kind, from the clouds' geometry (the median over
/// the targets of each cloud's median distance from its frame's origin, and the share of points
/// in front of it): sweeps around their sensor (median range > 5) → "lidar"; frames in a
/// camera's optical frame (≥ 90 % of the points at z > 0, median range 0.3–5) → "rgbd_frames";
/// anything else (objects, fragments, about their centroid) → "objects_resampled", the model
/// trained on independent samplings. `why` receives the measured values.
std::string presetForPairs(const std::vector<obmnet::RegistrationPair>& pairs, std::string* why);

}  // namespace obm::bench
