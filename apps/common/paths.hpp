#pragma once
/// \file paths.hpp
/// Finding the project's installed data (trained models, configs) from a tool: $OBM_SHARE_DIR, then
/// <executable>/../share/obmslam (an install), then the source tree the tool was built from.
#include <string>

namespace obm::apps {

/// Folder of the running executable (/proc/self/exe), "." when it cannot be read.
std::string executableDir();

/// The source tree the tools were built from (compiled into paths.cpp alone).
std::string sourceDir();

/// Path of `relative` (e.g. "models/obmnet_objects.pt") under the first share folder that has it;
/// the source-tree path when none has it (so the error message names a sensible place).
std::string findShareFile(const std::string& relative);

/// Path of a config file (e.g. "obmnet/train_objects.yaml"): $OBM_CONFIG_DIR, then
/// <executable>/../share/obmslam/config (an install), then the source tree's config/.
std::string findConfigFile(const std::string& relative);

}  // namespace obm::apps
