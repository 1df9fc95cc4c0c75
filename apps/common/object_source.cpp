#include "object_source.hpp"

#include <algorithm>
#include <cstdlib>
#include <filesystem>

#include "obm/config/config_node.hpp"
#include "obm/core/errors.hpp"
#include "obm/core/log.hpp"
#include "obm/io/mesh_io.hpp"

namespace fs = std::filesystem;

namespace obm::apps {

ObjectSourceConfig ObjectSourceConfig::load(const ConfigNode& node) {
  ObjectSourceConfig c;
  node.checkKeys({"source", "dir", "objects"});
  node.get("source", c.source);
  node.get("dir", c.dir);
  if (c.source != "cgal" && c.source != "meshes")
    throw ConfigError(node.where("source") + ": unknown source '" + c.source + "' (cgal, meshes)");
  c.objects = obmnet::ObjectSetOptions::load(node.child("objects"));
  return c;
}

namespace {
std::string defaultCgalDir() {
  if (const char* e = std::getenv("OBM_CGAL_DATA")) return e;
  const char* cache = std::getenv("OBM_CACHE");
  const char* home = std::getenv("HOME");
  const std::string base = cache ? cache : (std::string(home ? home : ".") + "/.cache/obmslam");
  return base + "/cgal/data/meshes";
}
}  // namespace

obmnet::ObjectSet loadObjectSet(const ObjectSourceConfig& config) {
  std::string dir = config.dir;
  if (dir.empty() && config.source == "cgal") dir = defaultCgalDir();
  if (!fs::is_directory(dir))
    throw IoError(dir + ": mesh folder not found" +
                  (config.source == "cgal"
                       ? " (run scripts/get_cgal_meshes.sh to fetch the CGAL meshes)"
                       : std::string()));
  std::vector<std::string> files;
  for (const auto& e : fs::directory_iterator(dir)) {
    auto ext = e.path().extension().string();
    std::transform(ext.begin(), ext.end(), ext.begin(), ::tolower);
    if (e.is_regular_file() && (ext == ".off" || ext == ".ply" || ext == ".obj"))
      files.push_back(e.path().string());
  }
  std::sort(files.begin(), files.end());
  std::vector<TriangleMesh> meshes;
  for (const auto& f : files) {
    try {
      meshes.push_back(io::readMesh(f));
      meshes.back().name = fs::path(f).stem().string();
    } catch (const Error& e) {
      OBM_LOG_WARN("objects", "skipping " << f << ": " << e.what());
    }
  }
  if (meshes.empty()) throw IoError(dir + ": no readable .off/.ply/.obj mesh");
  return obmnet::buildObjectSet(meshes, config.objects);
}

}  // namespace obm::apps
