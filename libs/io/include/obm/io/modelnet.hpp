#pragma once
/// \file modelnet.hpp
/// ModelNet40 in the HDF5 layout of PointNet (`modelnet40_ply_hdf5_2048`): each `.h5` file holds a
/// dataset `data` (float32, B × N × 3, N = 2048 points sampled on the shape, unit-sphere
/// normalised) and a dataset `label` (uint8, B × 1, the class index 0-39 into `shape_names.txt`);
/// the folder lists its files in `train_files.txt` and `test_files.txt`, one path per line (usually
/// prefixed `data/modelnet40_ply_hdf5_2048/`; files are looked up by their name in the folder).
///
/// Errors: IoError when a file cannot be opened, FormatError naming the file and the dataset when a
/// dataset is missing or has the wrong shape. HDF5 is not thread-safe in Debian's build: call these
/// from one thread at a time.
#include <string>
#include <vector>

#include "obm/core/point_cloud.hpp"

namespace obm::io {

/// One shape: its points (frame "object") and its class index.
struct LabeledCloud {
  PointCloud cloud;
  int label = -1;
};

/// Names of the datasets inside a file (the defaults are ModelNet40's).
struct ModelNetOptions {
  std::string data_dataset = "data";    ///< B × N × 3 points (any float type)
  std::string label_dataset = "label";  ///< B or B × 1 class indices (any integer type)
};

/// The two splits of the folder.
enum class ModelNetSplit { Train, Test };

/// Reads every shape of one `.h5` file.
std::vector<LabeledCloud> readModelNetH5(const std::string& path,
                                         const ModelNetOptions& options = {});

/// Paths of the files of a split, from `<dir>/train_files.txt` or `<dir>/test_files.txt`, each
/// resolved by its file name inside `dir`. Throws IoError when the list or a listed file is
/// missing (naming both).
std::vector<std::string> modelNetSplitFiles(const std::string& dir, ModelNetSplit split);

/// Reads every shape of a split, in the order of the list.
std::vector<LabeledCloud> readModelNet40(const std::string& dir, ModelNetSplit split,
                                         const ModelNetOptions& options = {});

/// The class names of `<dir>/shape_names.txt` (index = label); empty lines skipped.
std::vector<std::string> readModelNetShapeNames(const std::string& dir);

/// Writes shapes in the same layout (float32 `data` B × N × 3, uint8 `label` B × 1), atomically.
/// Every cloud must have the same number of points N ≥ 1 and a label in [0, 255]; throws
/// ContractError otherwise and IoError when the file cannot be written.
void writeModelNetH5(const std::string& path, const std::vector<LabeledCloud>& shapes,
                     const ModelNetOptions& options = {});

}  // namespace obm::io
