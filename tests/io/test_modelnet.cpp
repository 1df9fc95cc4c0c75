#include <gtest/gtest.h>
#include <hdf5.h>

#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include "obm/core/errors.hpp"
#include "obm/io/modelnet.hpp"
#include "test_data.hpp"

using namespace obm;
namespace fs = std::filesystem;

namespace {

/// Writes a ModelNet40-style file with the HDF5 C API directly (independent of the library's
/// writer): `data` float32 B×N×3 with point i of shape b at (b, i, -i), `label` uint8 B×1 = 3b+1.
void writeH5(const std::string& path, hsize_t B, hsize_t N, const char* data_name = "data",
             const char* label_name = "label") {
  std::vector<float> xyz;
  for (hsize_t b = 0; b < B; ++b)
    for (hsize_t i = 0; i < N; ++i) xyz.insert(xyz.end(), {float(b), float(i) * 0.5f, -float(i)});
  std::vector<std::uint8_t> labels;
  for (hsize_t b = 0; b < B; ++b) labels.push_back(static_cast<std::uint8_t>(3 * b + 1));
  const hid_t f = H5Fcreate(path.c_str(), H5F_ACC_TRUNC, H5P_DEFAULT, H5P_DEFAULT);
  ASSERT_GE(f, 0);
  const hsize_t dd[3] = {B, N, 3}, ld[2] = {B, 1};
  const hid_t ds = H5Screate_simple(3, dd, nullptr), ls = H5Screate_simple(2, ld, nullptr);
  const hid_t d =
      H5Dcreate2(f, data_name, H5T_IEEE_F32LE, ds, H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT);
  const hid_t l =
      H5Dcreate2(f, label_name, H5T_STD_U8LE, ls, H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT);
  EXPECT_GE(H5Dwrite(d, H5T_NATIVE_FLOAT, H5S_ALL, H5S_ALL, H5P_DEFAULT, xyz.data()), 0);
  EXPECT_GE(H5Dwrite(l, H5T_NATIVE_UINT8, H5S_ALL, H5S_ALL, H5P_DEFAULT, labels.data()), 0);
  H5Dclose(d), H5Dclose(l), H5Sclose(ds), H5Sclose(ls), H5Fclose(f);
}

template <typename E, typename Fn>
void expectThrowWith(Fn fn, std::initializer_list<std::string> fragments) {
  try {
    fn();
    ADD_FAILURE() << "nothing thrown";
  } catch (const E& e) {
    for (const auto& f : fragments)
      EXPECT_NE(std::string(e.what()).find(f), std::string::npos)
          << "'" << f << "' missing in: " << e.what();
  }
}

}  // namespace

TEST(ModelNet, ReadsFileWrittenWithTheCApi) {
  const auto dir = test::scratchDir("modelnet_read");
  writeH5(dir + "/ply_data_train0.h5", 3, 16);
  const auto shapes = io::readModelNetH5(dir + "/ply_data_train0.h5");
  ASSERT_EQ(shapes.size(), 3u);
  for (std::size_t b = 0; b < 3; ++b) {
    EXPECT_EQ(shapes[b].label, static_cast<int>(3 * b + 1));
    ASSERT_EQ(shapes[b].cloud.size(), 16u);
    EXPECT_EQ(shapes[b].cloud.points[5], Vector3f(float(b), 2.5f, -5.f));
  }
}

TEST(ModelNet, SplitListsResolveByFileName) {
  const auto dir = test::scratchDir("modelnet_split");
  writeH5(dir + "/ply_data_train0.h5", 2, 4);
  writeH5(dir + "/ply_data_train1.h5", 1, 4);
  writeH5(dir + "/ply_data_test0.h5", 1, 4);
  std::ofstream(dir + "/train_files.txt") << "data/modelnet40_ply_hdf5_2048/ply_data_train0.h5\n"
                                             "data/modelnet40_ply_hdf5_2048/ply_data_train1.h5\n\n";
  std::ofstream(dir + "/test_files.txt") << "ply_data_test0.h5\n";
  std::ofstream(dir + "/shape_names.txt") << "airplane\nbathtub\n";
  const auto train = io::readModelNet40(dir, io::ModelNetSplit::Train);
  ASSERT_EQ(train.size(), 3u);
  EXPECT_EQ(train[2].label, 1);  // first shape of the second file
  EXPECT_EQ(io::readModelNet40(dir, io::ModelNetSplit::Test).size(), 1u);
  EXPECT_EQ(io::readModelNetShapeNames(dir), (std::vector<std::string>{"airplane", "bathtub"}));
  std::ofstream(dir + "/test_files.txt") << "ply_data_test0.h5\nmissing.h5\n";
  expectThrowWith<IoError>([&] { io::modelNetSplitFiles(dir, io::ModelNetSplit::Test); },
                           {"test_files.txt:2", "missing.h5"});
}

TEST(ModelNet, WrongDatasetNamesAndShapes) {
  const auto dir = test::scratchDir("modelnet_bad");
  const std::string p = dir + "/pts.h5";
  writeH5(p, 2, 4, "points", "label");
  expectThrowWith<FormatError>([&] { io::readModelNetH5(p); }, {p, "'data'"});
  io::ModelNetOptions opt;
  opt.data_dataset = "points";
  EXPECT_EQ(io::readModelNetH5(p, opt).size(), 2u);
  opt.label_dataset = "labels";
  expectThrowWith<FormatError>([&] { io::readModelNetH5(p, opt); }, {p, "'labels'"});
  // Label count that does not match the shapes: data from one file, labels named like data.
  opt.label_dataset = "points";
  expectThrowWith<FormatError>([&] { io::readModelNetH5(p, opt); }, {p, "'points'", "shape"});
  std::ofstream(dir + "/text.h5") << "not hdf5";
  expectThrowWith<FormatError>([&] { io::readModelNetH5(dir + "/text.h5"); }, {"text.h5", "HDF5"});
  EXPECT_THROW(io::readModelNetH5(dir + "/none.h5"), IoError);
}

TEST(ModelNet, WriterRoundTrip) {
  const auto dir = test::scratchDir("modelnet_write");
  std::vector<io::LabeledCloud> shapes(2);
  for (int b = 0; b < 2; ++b) {
    shapes[b].label = 39 - b;
    for (int i = 0; i < 5; ++i) shapes[b].cloud.points.emplace_back(0.1f * i, -0.2f * b, 1.f / 3);
  }
  const std::string p = dir + "/out.h5";
  io::writeModelNetH5(p, shapes);
  const auto r = io::readModelNetH5(p);
  ASSERT_EQ(r.size(), 2u);
  EXPECT_EQ(r[1].label, 38);
  EXPECT_EQ(r[1].cloud.points, shapes[1].cloud.points);
  shapes[1].cloud.points.pop_back();
  EXPECT_THROW(io::writeModelNetH5(dir + "/bad.h5", shapes), ContractError);
  EXPECT_FALSE(fs::exists(dir + "/bad.h5"));
  EXPECT_THROW(io::writeModelNetH5(dir + "/no/such/dir.h5", {}), IoError);
}

TEST(ModelNet, ShapeNotBackedByTheFileIsAFormatErrorBeforeAnyAllocation) {
  // Found by tests/fuzz (scripts/fuzz.sh hdf5): a 2 kB file whose 'data' header claims a shape of
  // 3 GB. The reader sized its buffer from the header and ran out of memory; it must compare the
  // claim with the bytes the file stores first.
  const std::string found =
      obm::test::sourceDir() + "/tests/fuzz/regressions/hdf5/shape_claims_3gb.h5";
  ASSERT_TRUE(fs::exists(found));
  expectThrowWith<FormatError>([&] { io::readModelNetH5(found); }, {found, "stores"});
  // A second finding: a metadata entry whose size field asks HDF5 for 134 TB. The allocation
  // fails inside the library (NULL, as from glibc), which reports it as a read error.
  const std::string meta =
      obm::test::sourceDir() + "/tests/fuzz/regressions/hdf5/metadata_size_134tb.h5";
  ASSERT_TRUE(fs::exists(meta));
  EXPECT_THROW(io::readModelNetH5(meta), Error);
  // A third: a 2 kB file whose layout message claims more stored bytes than the file holds, so the
  // shape looked backed by them. The claim is bounded by the file's size.
  const std::string storage =
      obm::test::sourceDir() + "/tests/fuzz/regressions/hdf5/storage_claims_beyond_file.h5";
  ASSERT_TRUE(fs::exists(storage));
  expectThrowWith<FormatError>([&] { io::readModelNetH5(storage); }, {storage, "stores"});

  // The same claim made by a well-formed file: a dataset declared with a large shape and never
  // written (HDF5 allocates its storage lazily, so the file stays small).
  const auto dir = test::scratchDir("modelnet_unwritten");
  const std::string p = dir + "/unwritten.h5";
  {
    const hid_t f = H5Fcreate(p.c_str(), H5F_ACC_TRUNC, H5P_DEFAULT, H5P_DEFAULT);
    const hsize_t dims[3] = {100000, 2048, 3}, ldims[2] = {100000, 1};
    const hid_t s = H5Screate_simple(3, dims, nullptr), ls = H5Screate_simple(2, ldims, nullptr);
    const hid_t dcpl = H5Pcreate(H5P_DATASET_CREATE);
    H5Pset_alloc_time(dcpl, H5D_ALLOC_TIME_LATE);
    const hid_t d = H5Dcreate2(f, "data", H5T_IEEE_F32LE, s, H5P_DEFAULT, dcpl, H5P_DEFAULT);
    const hid_t l = H5Dcreate2(f, "label", H5T_STD_U8LE, ls, H5P_DEFAULT, dcpl, H5P_DEFAULT);
    H5Dclose(d), H5Dclose(l), H5Pclose(dcpl), H5Sclose(s), H5Sclose(ls), H5Fclose(f);
  }
  EXPECT_LT(fs::file_size(p), 100000u);
  expectThrowWith<FormatError>([&] { io::readModelNetH5(p); },
                               {p, "'data'", "100000 x 2048 x 3", "stores 0 bytes"});
}
