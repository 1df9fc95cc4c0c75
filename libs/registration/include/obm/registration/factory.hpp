#pragma once
/// \file factory.hpp
/// A scan matcher assembled from YAML:
/// \code{.yaml}
/// type: obmnet+icp          # icp | obmnet | obmnet+icp | obmm+icp
/// icp: {max_correspondence_distance: 1.0, kernel: huber, kernel_scale: 0.1}
/// obmnet: {model_path: ../../share/obmslam/obmnet_kitti.pt, pre_align: true}
/// confidence: {inlier_threshold: 0.2}
/// \endcode
/// or a preset with overrides: `{preset: ../presets/lidar.yaml, obmnet: {threads: 1}}`.
/// See config/registration/*.yaml for every key with its default.
#include <memory>
#include <string>

#include "obm/registration/obmnet_matcher.hpp"
#include "obm/registration/params.hpp"
#include "obm/registration/scan_matcher.hpp"

namespace obm {
class ConfigNode;
}  // namespace obm

namespace obm::registration {

/// The scan matchers the factory builds (YAML `type`, obm-map's `--matcher`).
enum class MatcherKind {
  Icp,             ///< "icp": ICP from the guess
  ObmNet,          ///< "obmnet": the network alone
  ObmNetIcp,       ///< "obmnet+icp": the network's pose refined by ICP
  ObmmIcp,         ///< "obmm+icp": ICP weighted by the Overlap Bias Matching Module
};

/// The YAML name of `kind` ("icp", "obmnet", "obmnet+icp", "obmm+icp").
const char* toString(MatcherKind kind);
/// The kind `name` names. Throws ConfigError "`where`: unknown matcher type 'name' (icp, obmnet,
/// obmnet+icp, obmm+icp)" when it names none (`where`: the key or option, e.g. node.where("type")).
MatcherKind parseMatcherKind(const std::string& name, const std::string& where);
/// Whether the matcher runs the network (and needs a model file).
inline bool usesNetwork(MatcherKind kind) { return kind != MatcherKind::Icp; }

/// Everything needed to build a matcher.
struct ScanMatcherConfig {
  MatcherKind type = MatcherKind::Icp;
  IcpParams icp;
  ObmNetMatcherParams obmnet;  ///< only for the OBMNet types
  ConfidenceParams confidence;

  /// Reads `type`, `icp`, `obmnet` (required for the OBMNet types), `confidence`; unknown keys
  /// and unknown types throw ConfigError naming file and key. With `preset: FILE` (a matcher
  /// preset, config/presets/<kind>.yaml, relative to this YAML) the preset's `matcher:` is read
  /// with this map's other keys laid over it, key by key.
  static ScanMatcherConfig load(const ConfigNode& node);
};

/// Builds the matcher `config.type` names (loads the model for the OBMNet types).
std::unique_ptr<ScanMatcher> makeScanMatcher(const ScanMatcherConfig& config);

}  // namespace obm::registration
