// libs/bench: the shipped presets load (with --set overrides), a folder of pairs gets the preset
// of its kind from its clouds, and row names parse once or are refused with the list.
#include <gtest/gtest.h>

#include <cmath>
#include <string>
#include <vector>

#include "obm/bench/methods.hpp"
#include "obm/bench/preset.hpp"
#include "obm/core/errors.hpp"
#include "test_data.hpp"

namespace obm {
namespace {

std::string presetFile(const std::string& name) {
  return test::sourceDir() + "/config/presets/" + name + ".yaml";
}

/// A pair whose target is `points` (the source is the same; only the target is looked at).
obmnet::RegistrationPair pairOf(const std::vector<Vector3f>& points) {
  obmnet::RegistrationPair p;
  p.target.points = points;
  p.source.points = points;
  return p;
}

TEST(BenchPresets, EveryProtocolHasAShippedPresetThatLoads) {
  for (const char* name : {"clean", "jitter", "outliers", "partial", "partial_noise", "resampled",
                           "indoor", "icl", "rgbd_frames", "kitti"}) {
    SCOPED_TRACE(name);
    const bench::Protocol protocol = bench::parseProtocol(name, "--protocol");
    EXPECT_EQ(std::string(bench::toString(protocol)), name);
    const bench::Preset preset = bench::Preset::load(presetFile(bench::presetName(protocol)));
    EXPECT_FALSE(preset.bench.data_config.empty());
    EXPECT_FALSE(preset.bench.rows.empty());
    // Every default row is a row the registry knows (open3d expands to the peers).
    EXPECT_NO_THROW(bench::expandRows(preset.bench.rows, preset.file, false));
  }
  EXPECT_THROW(bench::parseProtocol("kitty", "--protocol"), ConfigError);
}

TEST(BenchPresets, SetOverridesAKeyAndRefusesAMisspeltOne) {
  const bench::Preset plain = bench::Preset::load(presetFile("lidar"));
  EXPECT_EQ(plain.bench.recall_deg, 1.0);
  EXPECT_EQ(plain.matcher.obmnet.search_candidates, 8);
  const bench::Preset changed = bench::Preset::load(
      presetFile("lidar"), {"benchmark.recall_deg=5", "matcher.obmnet.search_candidates=4"});
  EXPECT_EQ(changed.bench.recall_deg, 5.0);
  EXPECT_EQ(changed.matcher.obmnet.search_candidates, 4);
  EXPECT_EQ(changed.matcher.icp.kernel_scale, plain.matcher.icp.kernel_scale);
  try {
    bench::Preset::load(presetFile("lidar"), {"benchmark.recal_deg=5"});
    ADD_FAILURE() << "a misspelt key was accepted";
  } catch (const ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find("recal_deg"), std::string::npos) << e.what();
  }
}

TEST(BenchPresets, AFolderOfPairsGetsThePresetOfItsKind) {
  // A sweep: points all around its sensor, 3–40 m away.
  std::vector<Vector3f> sweep, frame, object;
  for (int i = 0; i < 2000; ++i) {
    const double a = 2.0 * M_PI * i / 2000.0, r = 3.0 + 37.0 * ((i * 7919) % 2000) / 2000.0;
    sweep.emplace_back(static_cast<float>(r * std::cos(a)), static_cast<float>(r * std::sin(a)),
                       static_cast<float>(-1.7 + 0.001 * (i % 100)));
    // A depth frame: in front of the camera (z forward), 0.5–4 m away.
    const double x = -1.0 + 2.0 * (i % 50) / 50.0, y = -0.8 + 1.6 * (i / 50) / 40.0;
    frame.emplace_back(static_cast<float>(x), static_cast<float>(y),
                       static_cast<float>(0.5 + 3.5 * ((i * 31) % 2000) / 2000.0));
    // An object in the unit sphere, about its centroid.
    object.emplace_back(static_cast<float>(0.5 * std::cos(a)), static_cast<float>(0.5 * std::sin(a)),
                        static_cast<float>(0.3 * std::cos(3.0 * a)));
  }
  std::string why;
  EXPECT_EQ(bench::presetForPairs({pairOf(sweep), pairOf(sweep)}, &why), "lidar") << why;
  EXPECT_EQ(bench::presetForPairs({pairOf(frame)}, &why), "rgbd_frames") << why;
  EXPECT_EQ(bench::presetForPairs({pairOf(object)}, &why), "objects_resampled") << why;
  EXPECT_NE(why.find("median range"), std::string::npos);
}

TEST(BenchPresets, RowNamesParseOnceAndUnknownOnesAreListed) {
  EXPECT_EQ(bench::parseRow("obmnet+icp+search", "--methods").row, bench::Row::ObmnetIcpSearch);
  EXPECT_EQ(bench::rowName(bench::Row::SearchIcp), "search+icp");
  EXPECT_EQ(bench::parseRow("o3d_fgr", "--methods").row, bench::Row::Open3d);
  try {
    bench::parseRow("obmnet+bogus", "--methods");
    ADD_FAILURE() << "an unknown row was accepted";
  } catch (const ConfigError& e) {
    const std::string what = e.what();
    EXPECT_NE(what.find("--methods"), std::string::npos) << what;
    EXPECT_NE(what.find("obmnet+icp|icp"), std::string::npos) << what;  // the list of rows
  }
  // Rows that need start turns are refused by name when the preset has none.
  const bench::Preset preset = bench::Preset::load(presetFile("objects"));
  try {
    bench::buildMethods(preset, {bench::parseRow("icp-turns", "--methods")}, {});
    ADD_FAILURE() << "icp-turns built without start turns";
  } catch (const ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find("benchmark.start_turn_deg"), std::string::npos)
        << e.what();
  }
}

}  // namespace
}  // namespace obm
