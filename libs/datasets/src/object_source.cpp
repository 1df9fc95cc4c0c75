#include "obm/datasets/object_source.hpp"

#include <algorithm>
#include <cstdlib>
#include <filesystem>

#include "obm/config/config_node.hpp"
#include "obm/core/errors.hpp"
#include "obm/core/log.hpp"
#include "obm/io/mesh_io.hpp"
#include "obm/io/modelnet.hpp"

namespace fs = std::filesystem;

namespace obm::datasets {

ObjectSourceConfig ObjectSourceConfig::load(const ConfigNode& node) {
  ObjectSourceConfig c;
  node.checkKeys({"source", "dir", "objects", "unseen_categories", "rgbd"});
  node.get("source", c.source);
  node.get("dir", c.dir);
  node.get("unseen_categories", c.unseen_categories);
  if (c.source != "cgal" && c.source != "meshes" && c.source != "modelnet40" &&
      c.source != "rgbd")
    throw ConfigError(node.where("source") + ": unknown source '" + c.source +
                      "' (cgal, meshes, modelnet40, rgbd; LiDAR scans: kitti)");
  if (c.source == "rgbd") {
    if (!node.has("rgbd")) throw ConfigError(node.where("rgbd") + ": source rgbd needs an rgbd: map");
    c.rgbd = RgbdFragmentOptions::load(node.child("rgbd"));
  }
  if (c.source == "modelnet40" && c.dir.empty())
    throw ConfigError(node.where("dir") +
                      ": source modelnet40 needs the folder of modelnet40_ply_hdf5_2048");
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

namespace {

/// ModelNet40 HDF5: shapes keep their first `keep_points` points (as RIENet keeps 1024 of 2048).
obmnet::ObjectSet loadModelNet40(const ObjectSourceConfig& config) {
  const auto& o = config.objects;
  const auto names = io::readModelNetShapeNames(config.dir);
  auto prepare = [&](io::LabeledCloud& s, const std::string& name) {
    if (s.cloud.size() < static_cast<std::size_t>(o.keep_points))
      throw FormatError(
          config.dir, 0,
          name + " has " + std::to_string(s.cloud.size()) +
              " points, fewer than objects.keep_points = " + std::to_string(o.keep_points));
    s.cloud.points.resize(static_cast<std::size_t>(o.keep_points));
    if (!s.cloud.intensity.empty()) s.cloud.intensity.resize(s.cloud.points.size());
    if (!s.cloud.colors.empty()) s.cloud.colors.resize(s.cloud.points.size());
    s.cloud.frame_id = name;
  };
  auto labelName = [&](int label) {
    return label >= 0 && label < static_cast<int>(names.size())
               ? names[static_cast<std::size_t>(label)]
               : std::to_string(label);
  };
  obmnet::ObjectSet set;
  auto train = io::readModelNet40(config.dir, io::ModelNetSplit::Train);
  for (std::size_t i = 0; i < train.size(); ++i) {
    if (config.unseen_categories && train[i].label >= 20) continue;
    const std::string name = "train_" + labelName(train[i].label) + "_" + std::to_string(i);
    prepare(train[i], name);
    // The validation share is drawn from the training files by name hash (no test_fraction here:
    // the test group is the test files).
    const bool val = obmnet::splitForName(name, o.val_fraction, 0.0) == obmnet::Split::Validation;
    (val ? set.val : set.train).push_back(std::move(train[i].cloud));
  }
  auto test = io::readModelNet40(config.dir, io::ModelNetSplit::Test);
  for (std::size_t i = 0; i < test.size(); ++i) {
    if (config.unseen_categories && test[i].label < 20) continue;
    prepare(test[i], "test_" + labelName(test[i].label) + "_" + std::to_string(i));
    set.test.push_back(std::move(test[i].cloud));
  }
  if (set.train.empty()) throw IoError(config.dir + ": no ModelNet40 training shape");
  return set;
}

}  // namespace

obmnet::ObjectSet loadObjectSet(const ObjectSourceConfig& config) {
  if (config.source == "modelnet40") return loadModelNet40(config);
  if (config.source == "rgbd")
    return loadRgbdFragments(config.dir, config.rgbd, config.objects.keep_points,
                             config.objects.seed);
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

}  // namespace obm::datasets
