#include "obm/config/overrides.hpp"

#include <sstream>

namespace obm {

namespace {

std::vector<std::string> splitPath(const std::string& path) {
  std::vector<std::string> parts;
  std::stringstream ss(path);
  std::string p;
  while (std::getline(ss, p, '.')) parts.push_back(p);
  return parts;
}

// Sets `path` (a.b.c) of the document to `value`; `what` starts every error message.
void setPath(ConfigNode& root, const std::string& path, const YAML::Node& value,
             const std::string& what) {
  const auto keys = splitPath(path);
  if (keys.empty()) throw ConfigError(what + ": empty key path");
  for (const auto& k : keys)
    if (k.empty()) throw ConfigError(what + ": empty key in '" + path + "'");

  // YAML::Node is a handle: assigning through `node[key]` edits the shared document. Walk with
  // reset() rather than `=`, which would overwrite the node being referred to.
  YAML::Node node;
  node.reset(root.yaml());
  if (!node.IsMap()) throw ConfigError(what + ": " + root.file() + " is not a map of keys");
  std::string walked;
  for (std::size_t i = 0; i + 1 < keys.size(); ++i) {
    walked += (walked.empty() ? "" : ".") + keys[i];
    if (!node.IsMap()) throw ConfigError(what + ": '" + walked + "' is not inside a map");
    YAML::Node next = node[keys[i]];
    if (!next.IsDefined() || next.IsNull()) {
      node[keys[i]] = YAML::Node(YAML::NodeType::Map);
      next.reset(node[keys[i]]);
    } else if (!next.IsMap()) {
      throw ConfigError(what + ": '" + walked + "' is a value, not a map");
    }
    node.reset(next);
  }
  if (!node.IsMap())
    throw ConfigError(what + ": the parent of '" + keys.back() + "' is not a map");
  node[keys.back()] = value;
}

}  // namespace

void applyOverride(ConfigNode& root, const std::string& assignment) {
  const auto eq = assignment.find('=');
  if (eq == std::string::npos)
    throw ConfigError("override '" + assignment + "': expected key.path=value");
  const std::string text = assignment.substr(eq + 1);
  YAML::Node value;
  try {
    value = YAML::Load(text);
  } catch (const YAML::Exception& e) {
    throw ConfigError("override '" + assignment + "': value is not YAML (" + e.msg + ")");
  }
  setPath(root, assignment.substr(0, eq), value, "override '" + assignment + "'");
}

void setValue(ConfigNode& root, const std::string& path, const YAML::Node& value) {
  setPath(root, path, value, "setting '" + path + "'");
}

std::string toYamlText(const ConfigNode& root) {
  YAML::Emitter out;
  out << root.yaml();
  return std::string(out.c_str()) + "\n";
}

void applyOverrides(ConfigNode& root, const std::vector<std::string>& assignments) {
  for (const auto& a : assignments) applyOverride(root, a);
}

}  // namespace obm
