#pragma once
/// \file factory.hpp
/// A scan matcher assembled from YAML:
/// \code{.yaml}
/// type: obmnet+icp          # icp | obmnet | obmnet+icp | obmm+icp
/// icp: {max_correspondence_distance: 1.0, kernel: huber, kernel_scale: 0.1}
/// obmnet: {model_path: ../../share/obmslam/obmnet_kitti.pt, pre_align: true}
/// confidence: {inlier_threshold: 0.2}
/// \endcode
/// See config/registration/*.yaml for every key with its default.
#include <memory>
#include <string>

#include "obm/registration/obmnet_matcher.hpp"
#include "obm/registration/params.hpp"
#include "obm/registration/scan_matcher.hpp"

namespace obm {

class ConfigNode;

/// Everything needed to build a matcher.
struct ScanMatcherConfig {
  std::string type = "icp";  ///< "icp", "obmnet", "obmnet+icp" or "obmm+icp"
  IcpParams icp;
  ObmNetMatcherParams obmnet;  ///< only for the OBMNet types
  ConfidenceParams confidence;

  /// Reads `type`, `icp`, `obmnet` (required for the OBMNet types), `confidence`; unknown keys
  /// and unknown types throw ConfigError naming file and key.
  static ScanMatcherConfig load(const ConfigNode& node);
};

/// Builds the matcher `config.type` names (loads the model for the OBMNet types).
std::unique_ptr<ScanMatcher> makeScanMatcher(const ScanMatcherConfig& config);

}  // namespace obm
