#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>

#include "obm/core/atomic_file.hpp"
#include "obm/core/errors.hpp"
#include "obm/core/log.hpp"
#include "obm/core/progress.hpp"
#include "test_data.hpp"

using namespace obm;
namespace fs = std::filesystem;

TEST(AtomicFile, WritesAndLeavesNothingOnFailure) {
  const std::string dir = test::scratchDir("atomic");
  const std::string path = dir + "/out.txt";
  writeTextAtomically(path, "first");
  EXPECT_THROW(writeFileAtomically(path, [](std::ostream& os) {
                 os << "partial";
                 throw std::runtime_error("interrupted");
               }),
               std::runtime_error);
  std::ifstream is(path);
  std::string s;
  is >> s;
  EXPECT_EQ(s, "first");  // old content kept
  int files = 0;
  for (const auto& e : fs::directory_iterator(dir)) (void)e, ++files;
  EXPECT_EQ(files, 1);  // no temporary left behind
  EXPECT_THROW(writeTextAtomically(dir + "/no/such/folder/x.txt", "x"), IoError);
}

TEST(Progress, FormatDuration) {
  EXPECT_EQ(ProgressBar::formatDuration(65), "1:05");
  EXPECT_EQ(ProgressBar::formatDuration(3725), "1:02:05");
  EXPECT_EQ(ProgressBar::formatDuration(-1), "--:--");
}

TEST(Log, ParseLevel) {
  EXPECT_EQ(parseLogLevel("warn"), LogLevel::Warn);
  EXPECT_THROW(parseLogLevel("loud"), ConfigError);
}

TEST(Errors, FormatErrorNamesFileAndLine) {
  const FormatError e("poses.txt", 12, "expected 12 numbers, got 11");
  EXPECT_EQ(std::string(e.what()), "poses.txt:12: expected 12 numbers, got 11");
  EXPECT_EQ(e.line(), 12u);
}
