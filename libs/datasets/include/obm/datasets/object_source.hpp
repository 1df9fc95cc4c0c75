#pragma once
/// \file object_source.hpp
/// Where the object-level tools (obm-train, obm-bench) get their objects: the `data:` map of their
/// YAML config. Shared by the tools; the sampling and splitting live in obm::obmnet.
#include <string>

#include "obm/datasets/fragment_source.hpp"
#include "obm/obmnet/object_set.hpp"

namespace obm::datasets {

struct ObjectSourceConfig {
  /// cgal: the CGAL sample meshes of Debian's libcgal-demo (fetched by scripts/get_cgal_meshes.sh);
  /// meshes: every .off/.ply/.obj in `dir`;
  /// modelnet40: PointNet's `modelnet40_ply_hdf5_2048` folder in `dir` (train_files.txt,
  /// test_files.txt, *.h5): the first `objects.keep_points` points of each shape; the test group
  /// is the test files, the validation split a `objects.val_fraction` share of the training
  /// shapes (by index hash), so the test files are never seen in training.
  /// rgbd: fragments of RGB-D sequences (fragment_source.hpp), split by sequence; `dir` is the
  /// folder of the sequences and `rgbd:` the options.
  std::string source = "cgal";
  /// modelnet40 only: RIENet's "unseen" protocol — training / validation from the shapes with
  /// label < 20, test from those with label >= 20.
  bool unseen_categories = false;
  std::string
      dir;  ///< mesh folder; empty with `cgal` = $OBM_CGAL_DATA, else the fetch script's cache
  obmnet::ObjectSetOptions objects;
  RgbdFragmentOptions rgbd;  ///< source rgbd only

  static ObjectSourceConfig load(const ConfigNode& node);
};

/// Reads the meshes and builds the split object set. Throws IoError naming the folder when it
/// holds no mesh.
obmnet::ObjectSet loadObjectSet(const ObjectSourceConfig& config);

}  // namespace obm::datasets
