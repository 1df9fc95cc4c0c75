#pragma once
/// \file config_node.hpp
/// Typed access to a YAML configuration with errors that name the file and the key path. Each
/// parameter struct has one `load(const ConfigNode&)` that reads its keys with `get` (optional:
/// the in-class default stays when the key is absent) or `required`, then calls `checkKeys` so a
/// misspelt key fails instead of being silently ignored.
#include <yaml-cpp/yaml.h>

#include <initializer_list>
#include <string>
#include <vector>

#include "obm/core/errors.hpp"

namespace obm {

class ConfigNode {
 public:
  ConfigNode() = default;
  ConfigNode(YAML::Node node, std::string file, std::string path);

  /// Loads a YAML file; throws IoError (missing) or ConfigError (syntax, with line) naming it.
  static ConfigNode loadFile(const std::string& file);
  /// Parses YAML text (`origin` is used in messages).
  static ConfigNode fromString(const std::string& text, const std::string& origin = "<string>");

  bool has(const std::string& key) const;
  bool valid() const { return node_.IsDefined() && !node_.IsNull(); }

  /// Sub-map `key`; when absent, an empty node (all `get`s keep defaults).
  ConfigNode child(const std::string& key) const;

  /// Reads `key` into `value` if present (keeps the default otherwise). Throws ConfigError naming
  /// file and key path when the value has the wrong type.
  template <typename T>
  void get(const std::string& key, T& value) const {
    if (!has(key)) return;
    value = as<T>(key);
  }

  /// Reads a required key; throws ConfigError naming file and key path when missing.
  template <typename T>
  T required(const std::string& key) const {
    if (!has(key)) throw ConfigError(where(key) + ": required key is missing");
    return as<T>(key);
  }

  /// Angles in config are degrees (`*_deg`); this reads one and returns radians.
  void getDegAsRad(const std::string& key, double& radians) const;

  /// Throws ConfigError naming the first key of this map that is not in `known`.
  void checkKeys(std::initializer_list<const char*> known) const;
  void checkKeys(const std::vector<std::string>& known) const;

  /// "file: a.b.key" for messages.
  std::string where(const std::string& key = {}) const;

  const YAML::Node& yaml() const { return node_; }
  const std::string& file() const { return file_; }

 private:
  template <typename T>
  T as(const std::string& key) const {
    try {
      return node_[key].as<T>();
    } catch (const YAML::Exception& e) {
      throw ConfigError(where(key) + ": invalid value (" + e.msg + ")");
    }
  }
  YAML::Node node_;
  std::string file_;
  std::string path_;
};

}  // namespace obm
