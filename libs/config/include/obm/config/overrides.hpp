#pragma once
/// \file overrides.hpp
/// Command-line overrides of a loaded YAML configuration, `--set model.use_nmm=false` style, so
/// that a variant of a config (an ablation, a different learning rate) does not need a copied file.
/// The value is parsed as YAML (`false`, `0.5`, `[12, 20]`, `text`); the parameter structs'
/// `checkKeys` still reject a misspelt key when the config is loaded afterwards.
#include <string>
#include <vector>

#include "obm/config/config_node.hpp"

namespace obm {

/// Applies one `a.b.c=value` assignment to `root` in place (YAML nodes share storage, so every
/// ConfigNode that refers to the same document sees it). Creates missing intermediate maps.
/// Throws ConfigError naming the assignment when it has no `=`, an empty key path, a value that is
/// not YAML, or a path that runs through a value that is not a map.
void applyOverride(ConfigNode& root, const std::string& assignment);

/// Sets `a.b.c` of `root` to `value` in place (the typed form of applyOverride, for values that
/// come from command-line options, e.g. a folder name that YAML would not read back as text).
/// Throws ConfigError as applyOverride.
void setValue(ConfigNode& root, const std::string& path, const YAML::Node& value);

/// The document of `root` as YAML text (comments are not kept), so that a program can record the
/// exact configuration it ran with; loading that text gives the same parameters.
std::string toYamlText(const ConfigNode& root);

/// Applies each assignment in order.
void applyOverrides(ConfigNode& root, const std::vector<std::string>& assignments);

}  // namespace obm
