#pragma once
/// \file object_source.hpp
/// Where the object-level tools (obm-train, obm-bench) get their objects: the `data:` map of their
/// YAML config. Shared by the tools; the sampling and splitting live in obm::obmnet.
#include <string>

#include "obm/obmnet/object_set.hpp"

namespace obm::apps {

struct ObjectSourceConfig {
  /// cgal: the CGAL sample meshes of Debian's libcgal-demo (fetched by scripts/get_cgal_meshes.sh);
  /// meshes: every .off/.ply/.obj in `dir`.
  std::string source = "cgal";
  std::string
      dir;  ///< mesh folder; empty with `cgal` = $OBM_CGAL_DATA, else the fetch script's cache
  obmnet::ObjectSetOptions objects;

  static ObjectSourceConfig load(const ConfigNode& node);
};

/// Reads the meshes and builds the split object set. Throws IoError naming the folder when it
/// holds no mesh.
obmnet::ObjectSet loadObjectSet(const ObjectSourceConfig& config);

}  // namespace obm::apps
