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

inline std::string sharedDataDir() {
  if (const char* env = std::getenv("OBM_SHARED_DATA")) return env;
  return std::string(OBM_SOURCE_DIR) + "/../shared/data";
}

inline bool inCI() {
  const char* ci = std::getenv("CI");
  return ci && std::string(ci) != "" && std::string(ci) != "0" && std::string(ci) != "false";
}

/// A fresh empty scratch folder under the build tree for one test.
inline std::string scratchDir(const std::string& name) {
  const auto p = std::filesystem::path(OBM_BINARY_DIR) / "test_scratch" / name;
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
