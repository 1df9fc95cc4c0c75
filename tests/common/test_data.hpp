#pragma once
// Locating the real reference data (../shared/data beside the checkout, or $OBM_SHARED_DATA).
// A test that needs it fails loudly in CI (CI=true) when it is missing, and skips elsewhere.
#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <string>

namespace obm::test {

/// The project's source folder (configs, models, fuzz regressions) and this build's folder
/// (tests/common/test_paths.cpp).
std::string sourceDir();
std::string binaryDir();

inline std::string sharedDataDir() {
  if (const char* env = std::getenv("OBM_SHARED_DATA")) return env;
  return sourceDir() + "/../shared/data";
}

/// The shipped models (share/obmslam/models/, with the trailing slash), or $OBM_TEST_MODELS:
/// scripts/check_models_matter.sh points it at a copy where one model is replaced by an untrained
/// network of the same shape, to show that some test fails.
inline std::string modelsDir() {
  if (const char* env = std::getenv("OBM_TEST_MODELS")) return std::string(env) + "/";
  return sourceDir() + "/share/obmslam/models/";
}

inline bool inCI() {
  const char* ci = std::getenv("CI");
  return ci && std::string(ci) != "" && std::string(ci) != "0" && std::string(ci) != "false";
}

/// A fresh empty scratch folder under the build tree, of the running test alone:
/// test_scratch/<Suite.Test>/<name>. ctest runs every test in its own process, several at once
/// (-j), so two tests asking for the same `name` must not remove each other's files.
inline std::string scratchDir(const std::string& name) {
  std::string owner = "no_test";
  if (const auto* info = ::testing::UnitTest::GetInstance()->current_test_info())
    owner = std::string(info->test_suite_name()) + "." + info->name();
  for (char& c : owner)
    if (c == '/') c = '_';  // parameterised tests: Suite/Test/0
  const auto p = std::filesystem::path(binaryDir()) / "test_scratch" / owner / name;
  std::filesystem::remove_all(p);
  std::filesystem::create_directories(p);
  return p.string();
}

/// A 4×4 matrix of 16 whitespace-separated numbers (the reference poses of shared/data's pairs).
inline Eigen::Isometry3d readMatrix4(const std::string& path) {
  std::ifstream in(path);
  Eigen::Matrix4d M;
  for (int r = 0; r < 4; ++r)
    for (int c = 0; c < 4; ++c) in >> M(r, c);
  EXPECT_TRUE(in.good() || in.eof()) << path;
  Eigen::Isometry3d T;
  T.matrix() = M;
  return T;
}

}  // namespace obm::test

/// Use at the top of a test that reads CGAL's sample meshes ($OBM_CGAL_DATA, which scripts/test.sh
/// sets from scripts/get_cgal_meshes.sh): fails in CI, skips elsewhere.
#define OBM_REQUIRE_CGAL_DATA()                                                             \
  do {                                                                                      \
    const char* obm_c_ = std::getenv("OBM_CGAL_DATA");                                      \
    if (obm_c_ == nullptr || !std::filesystem::is_directory(obm_c_)) {                      \
      if (::obm::test::inCI()) FAIL() << "CGAL meshes missing in CI (OBM_CGAL_DATA)";       \
      GTEST_SKIP() << "OBM_CGAL_DATA not set (scripts/get_cgal_meshes.sh)";                 \
    }                                                                                       \
  } while (0)

/// Use at the top of a test that reads ../shared/data/<sub>: fails in CI, skips elsewhere.
#define OBM_REQUIRE_SHARED_DATA(sub)                                                        \
  do {                                                                                      \
    const std::string obm_p_ = ::obm::test::sharedDataDir() + "/" + (sub);                  \
    if (!std::filesystem::exists(obm_p_)) {                                                 \
      if (::obm::test::inCI()) FAIL() << "reference data missing in CI: " << obm_p_;        \
      GTEST_SKIP() << "reference data not found: " << obm_p_                                \
                   << " (set OBM_SHARED_DATA to the shared/data folder)";                   \
    }                                                                                       \
  } while (0)
