#include "obm/config/config_node.hpp"

#include <filesystem>
#include <set>

#include "obm/core/se3.hpp"

namespace obm {

ConfigNode::ConfigNode(YAML::Node node, std::string file, std::string path)
    : node_(std::move(node)), file_(std::move(file)), path_(std::move(path)) {}

ConfigNode ConfigNode::loadFile(const std::string& file) {
  if (!std::filesystem::is_regular_file(file))
    throw IoError("config file '" + file + "' does not exist or is not a file");
  try {
    return ConfigNode(YAML::LoadFile(file), file, "");
  } catch (const YAML::ParserException& e) {
    throw ConfigError(file + ":" + std::to_string(e.mark.line + 1) + ": YAML syntax error: " + e.msg);
  } catch (const YAML::Exception& e) {
    throw ConfigError(file + ": cannot read YAML: " + e.msg);
  }
}

ConfigNode ConfigNode::fromString(const std::string& text, const std::string& origin) {
  try {
    return ConfigNode(YAML::Load(text), origin, "");
  } catch (const YAML::ParserException& e) {
    throw ConfigError(origin + ":" + std::to_string(e.mark.line + 1) + ": YAML syntax error: " + e.msg);
  }
}

bool ConfigNode::has(const std::string& key) const {
  if (!node_.IsMap()) return false;
  const YAML::Node n = node_[key];
  return n.IsDefined() && !n.IsNull();
}

ConfigNode ConfigNode::child(const std::string& key) const {
  const std::string p = path_.empty() ? key : path_ + "." + key;
  if (!has(key)) return ConfigNode(YAML::Node(), file_, p);
  if (!node_[key].IsMap()) throw ConfigError(where(key) + ": expected a map of keys");
  return ConfigNode(node_[key], file_, p);
}

void ConfigNode::getDegAsRad(const std::string& key, double& radians) const {
  if (!has(key)) return;
  radians = as<double>(key) * kDegToRad;
}

void ConfigNode::checkKeys(std::initializer_list<const char*> known) const {
  std::vector<std::string> v;
  for (const char* k : known) v.emplace_back(k);
  checkKeys(v);
}

void ConfigNode::checkKeys(const std::vector<std::string>& known) const {
  // An absent or empty section has no key to check; anything else must be a map of keys (a
  // plain-text file given as a configuration parses as one scalar).
  if (!valid()) return;
  if (!node_.IsMap())
    throw ConfigError((path_.empty() ? (file_.empty() ? std::string("<config>") : file_)
                                     : where()) +
                      ": expected a map of keys, found " +
                      (node_.IsSequence() ? "a list" : "the value '" + node_.Scalar().substr(0, 40) + "'"));
  const std::set<std::string> ks(known.begin(), known.end());
  for (const auto& kv : node_) {
    // YAML allows a map or a list as a key ("{a: 1}: 2"); no configuration has one.
    if (!kv.first.IsScalar()) {
      const auto m = kv.first.Mark();
      throw ConfigError(where() + ": a key that is not a name (a map or list used as a key, line " +
                        std::to_string(m.line + 1) + ")");
    }
    const std::string k = kv.first.as<std::string>();
    if (!ks.count(k)) {
      std::string list;
      for (const auto& s : known) list += (list.empty() ? "" : ", ") + s;
      throw ConfigError(where(k) + ": unknown key (known keys: " + list + ")");
    }
  }
}

std::string ConfigNode::where(const std::string& key) const {
  std::string p = path_;
  if (!key.empty()) p = p.empty() ? key : p + "." + key;
  return (file_.empty() ? std::string("<config>") : file_) + ": " + p;
}

}  // namespace obm
