#include "obm/io/modelnet.hpp"

#include <hdf5.h>

#include <cstdio>
#include <algorithm>
#include <filesystem>
#include <limits>

#include "obm/core/atomic_file.hpp"
#include "obm/core/errors.hpp"
#include "text_parse.hpp"

namespace obm::io {
namespace {
namespace fs = std::filesystem;

/// Closes an HDF5 identifier when it goes out of scope.
class H5Id {
 public:
  H5Id(hid_t id, herr_t (*close)(hid_t)) : id_(id), close_(close) {}
  ~H5Id() {
    if (id_ >= 0) close_(id_);
  }
  H5Id(const H5Id&) = delete;
  H5Id& operator=(const H5Id&) = delete;
  hid_t get() const noexcept { return id_; }
  bool ok() const noexcept { return id_ >= 0; }

 private:
  hid_t id_;
  herr_t (*close_)(hid_t);
};

/// Turns off HDF5's printing of its error stack while alive (the library reports errors through
/// exceptions instead), and restores the previous handler.
class SilenceH5Errors {
 public:
  SilenceH5Errors() {
    H5Eget_auto2(H5E_DEFAULT, &func_, &data_);
    H5Eset_auto2(H5E_DEFAULT, nullptr, nullptr);
  }
  ~SilenceH5Errors() { H5Eset_auto2(H5E_DEFAULT, func_, data_); }

 private:
  H5E_auto2_t func_ = nullptr;
  void* data_ = nullptr;
};

std::string shapeText(const std::vector<hsize_t>& dims) {
  std::string s;
  for (std::size_t i = 0; i < dims.size(); ++i) s += (i ? " x " : "") + std::to_string(dims[i]);
  return s.empty() ? "scalar" : s;
}

struct Dataset {
  std::vector<hsize_t> dims;
  H5T_class_t type_class = H5T_NO_CLASS;
  std::size_t element_bytes = 0;  ///< size of one stored element
  hsize_t storage_bytes = 0;      ///< bytes the file holds for the dataset's data
  int filters = 0;                ///< compression and other filters in its pipeline
};

/// Opens dataset `name`, checks that it exists, and returns its shape and element class.
/// `file_bytes` bounds the storage the dataset's header may claim.
Dataset describe(hid_t file, const std::string& path, const std::string& name,
                 hsize_t file_bytes) {
  if (H5Lexists(file, name.c_str(), H5P_DEFAULT) <= 0)
    throw FormatError(path, 0, "HDF5 file has no dataset '" + name + "'");
  H5Id ds(H5Dopen2(file, name.c_str(), H5P_DEFAULT), H5Dclose);
  if (!ds.ok()) throw FormatError(path, 0, "'" + name + "' is not a dataset");
  H5Id space(H5Dget_space(ds.get()), H5Sclose);
  H5Id type(H5Dget_type(ds.get()), H5Tclose);
  const int rank = space.ok() ? H5Sget_simple_extent_ndims(space.get()) : -1;
  if (rank < 0) throw FormatError(path, 0, "dataset '" + name + "': cannot read its shape");
  Dataset d;
  d.dims.resize(static_cast<std::size_t>(rank));
  if (rank > 0) H5Sget_simple_extent_dims(space.get(), d.dims.data(), nullptr);
  d.type_class = type.ok() ? H5Tget_class(type.get()) : H5T_NO_CLASS;
  d.element_bytes = type.ok() ? H5Tget_size(type.get()) : 0;
  d.storage_bytes = std::min(H5Dget_storage_size(ds.get()), file_bytes);
  H5Id plist(H5Dget_create_plist(ds.get()), H5Pclose);
  d.filters = plist.ok() ? std::max(0, H5Pget_nfilters(plist.get())) : 0;
  return d;
}

/// Checks, before anything is allocated, that the shape a dataset claims is backed by the bytes the
/// file stores: a corrupt or hostile header can claim billions of points in a file of a few
/// kilobytes. Uncompressed data must be all there; compressed data may be at most ~1000x smaller
/// (deflate's limit is 1032:1). Returns the number of elements.
std::size_t checkedElements(const Dataset& d, const std::string& path, const std::string& name) {
  std::size_t n = 1;
  for (const hsize_t dim : d.dims) {
    if (dim != 0 && n > std::numeric_limits<std::size_t>::max() / 16 / dim)
      throw FormatError(path, 0, "dataset '" + name + "' has shape " + shapeText(d.dims) +
                                     ": too large (corrupt header?)");
    n *= static_cast<std::size_t>(dim);
  }
  const std::size_t claimed = n * std::max<std::size_t>(d.element_bytes, 1);
  const std::size_t ratio = d.filters > 0 ? 1100 : 1;
  if (n > 0 && (d.storage_bytes == 0 || claimed / ratio > d.storage_bytes))
    throw FormatError(path, 0, "dataset '" + name + "' has shape " + shapeText(d.dims) + " (" +
                                   std::to_string(claimed) + " bytes) but the file stores " +
                                   std::to_string(d.storage_bytes) +
                                   " bytes of it (truncated or corrupt file?)");
  return n;
}

void readAll(hid_t file, const std::string& path, const std::string& name, hid_t mem_type,
             void* buf) {
  H5Id ds(H5Dopen2(file, name.c_str(), H5P_DEFAULT), H5Dclose);
  if (!ds.ok() || H5Dread(ds.get(), mem_type, H5S_ALL, H5S_ALL, H5P_DEFAULT, buf) < 0)
    throw FormatError(path, 0, "dataset '" + name + "': read failed (corrupt file?)");
}

std::string splitListName(ModelNetSplit split) {
  return split == ModelNetSplit::Train ? "train_files.txt" : "test_files.txt";
}

}  // namespace

std::vector<LabeledCloud> readModelNetH5(const std::string& path, const ModelNetOptions& options) {
  SilenceH5Errors quiet;
  if (!fs::is_regular_file(path)) throw IoError("cannot open '" + path + "': no such file");
  if (H5Fis_hdf5(path.c_str()) <= 0) throw FormatError(path, 0, "not an HDF5 file");
  H5Id file(H5Fopen(path.c_str(), H5F_ACC_RDONLY, H5P_DEFAULT), H5Fclose);
  if (!file.ok()) throw IoError("cannot open HDF5 file '" + path + "'");

  // The sizes a header claims are bounded by the file that holds them (a damaged layout message
  // can claim gigabytes of storage in a file of a few kilobytes).
  const hsize_t file_bytes = static_cast<hsize_t>(fs::file_size(path));
  const Dataset data = describe(file.get(), path, options.data_dataset, file_bytes);
  if (data.dims.size() != 3 || data.dims[2] != 3)
    throw FormatError(path, 0,
                      "dataset '" + options.data_dataset + "' has shape " + shapeText(data.dims) +
                          ", expected shapes x points x 3");
  if (data.type_class != H5T_FLOAT)
    throw FormatError(path, 0, "dataset '" + options.data_dataset + "' is not floating-point");
  const Dataset label = describe(file.get(), path, options.label_dataset, file_bytes);
  const bool label_ok =
      (label.dims.size() == 1 && label.dims[0] == data.dims[0]) ||
      (label.dims.size() == 2 && label.dims[0] == data.dims[0] && label.dims[1] == 1);
  if (!label_ok)
    throw FormatError(path, 0,
                      "dataset '" + options.label_dataset + "' has shape " + shapeText(label.dims) +
                          ", expected " + std::to_string(data.dims[0]) +
                          " x 1 (one label per shape in '" + options.data_dataset + "')");
  if (label.type_class != H5T_INTEGER)
    throw FormatError(path, 0, "dataset '" + options.label_dataset + "' is not integer");

  const std::size_t n_xyz = checkedElements(data, path, options.data_dataset);
  checkedElements(label, path, options.label_dataset);
  const std::size_t B = data.dims[0], N = data.dims[1];
  std::vector<float> xyz(n_xyz);
  std::vector<int> labels(B);
  // HDF5 converts from the stored types (float32/float64, uint8/int...) to the native ones.
  if (B > 0) {
    readAll(file.get(), path, options.data_dataset, H5T_NATIVE_FLOAT, xyz.data());
    readAll(file.get(), path, options.label_dataset, H5T_NATIVE_INT, labels.data());
  }
  std::vector<LabeledCloud> out(B);
  for (std::size_t b = 0; b < B; ++b) {
    auto& c = out[b].cloud;
    c.frame_id = "object";
    c.points.resize(N);
    const float* p = xyz.data() + b * N * 3;
    for (std::size_t i = 0; i < N; ++i)
      c.points[i] = Vector3f(p[3 * i], p[3 * i + 1], p[3 * i + 2]);
    out[b].label = labels[b];
  }
  return out;
}

std::vector<std::string> modelNetSplitFiles(const std::string& dir, ModelNetSplit split) {
  const std::string list = (fs::path(dir) / splitListName(split)).string();
  const std::string text = detail::readWholeFile(list);
  detail::LineCursor cur(text);
  std::string_view line;
  std::vector<std::string> files;
  while (cur.next(line)) {
    line = detail::trim(line);
    if (line.empty()) continue;
    // Lists name the files as e.g. data/modelnet40_ply_hdf5_2048/ply_data_train0.h5: only the
    // file name is used, inside `dir`.
    const fs::path p = fs::path(dir) / fs::path(std::string(line)).filename();
    if (!fs::is_regular_file(p))
      throw IoError(list + ":" + std::to_string(cur.lineNumber()) + ": listed file '" +
                    std::string(line) + "' not found as " + p.string());
    files.push_back(p.string());
  }
  return files;
}

std::vector<LabeledCloud> readModelNet40(const std::string& dir, ModelNetSplit split,
                                         const ModelNetOptions& options) {
  std::vector<LabeledCloud> all;
  for (const auto& f : modelNetSplitFiles(dir, split)) {
    auto part = readModelNetH5(f, options);
    all.insert(all.end(), std::make_move_iterator(part.begin()),
               std::make_move_iterator(part.end()));
  }
  return all;
}

std::vector<std::string> readModelNetShapeNames(const std::string& dir) {
  const std::string text = detail::readWholeFile((fs::path(dir) / "shape_names.txt").string());
  detail::LineCursor cur(text);
  std::string_view line;
  std::vector<std::string> names;
  while (cur.next(line)) {
    line = detail::trim(line);
    if (!line.empty()) names.emplace_back(line);
  }
  return names;
}

void writeModelNetH5(const std::string& path, const std::vector<LabeledCloud>& shapes,
                     const ModelNetOptions& options) {
  const std::size_t B = shapes.size();
  const std::size_t N = B ? shapes[0].cloud.size() : 0;
  if (B > 0 && N == 0) throw ContractError("writeModelNetH5: shapes have no points");
  std::vector<float> xyz;
  xyz.reserve(B * N * 3);
  std::vector<std::uint8_t> labels(B);
  for (std::size_t b = 0; b < B; ++b) {
    const auto& s = shapes[b];
    if (s.cloud.size() != N)
      throw ContractError("writeModelNetH5: shape " + std::to_string(b) + " has " +
                          std::to_string(s.cloud.size()) + " points, shape 0 has " +
                          std::to_string(N));
    if (s.label < 0 || s.label > 255)
      throw ContractError("writeModelNetH5: shape " + std::to_string(b) + " has label " +
                          std::to_string(s.label) + " outside [0, 255]");
    labels[b] = static_cast<std::uint8_t>(s.label);
    for (const auto& p : s.cloud.points) xyz.insert(xyz.end(), {p.x(), p.y(), p.z()});
  }
  const fs::path parent = fs::path(path).parent_path();
  if (!parent.empty() && !fs::is_directory(parent))
    throw IoError("cannot write '" + path + "': folder '" + parent.string() + "' does not exist");

  SilenceH5Errors quiet;
  const std::string tmp = temporaryPathFor(path);
  bool ok = false;
  {
    H5Id file(H5Fcreate(tmp.c_str(), H5F_ACC_TRUNC, H5P_DEFAULT, H5P_DEFAULT), H5Fclose);
    if (file.ok()) {
      const hsize_t ddims[3] = {B, N, 3};
      const hsize_t ldims[2] = {B, 1};
      H5Id dspace(H5Screate_simple(3, ddims, nullptr), H5Sclose);
      H5Id lspace(H5Screate_simple(2, ldims, nullptr), H5Sclose);
      H5Id dset(H5Dcreate2(file.get(), options.data_dataset.c_str(), H5T_IEEE_F32LE, dspace.get(),
                           H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT),
                H5Dclose);
      H5Id lset(H5Dcreate2(file.get(), options.label_dataset.c_str(), H5T_STD_U8LE, lspace.get(),
                           H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT),
                H5Dclose);
      ok = dset.ok() && lset.ok() &&
           (B == 0 || (H5Dwrite(dset.get(), H5T_NATIVE_FLOAT, H5S_ALL, H5S_ALL, H5P_DEFAULT,
                                xyz.data()) >= 0 &&
                       H5Dwrite(lset.get(), H5T_NATIVE_UINT8, H5S_ALL, H5S_ALL, H5P_DEFAULT,
                                labels.data()) >= 0));
    }
  }  // every handle closed here, so the file is complete on disk
  if (!ok) {
    std::remove(tmp.c_str());
    throw IoError("cannot write HDF5 file '" + path + "'");
  }
  commitTemporaryFile(tmp, path);
}

}  // namespace obm::io
