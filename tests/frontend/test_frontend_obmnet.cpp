// The front-end with the OBMNet + ICP matcher for loop verification (and recovery), on the
// simulated loop, with a small random model written here: plumbing, not the network's accuracy —
// the ICP stage must still verify the loop exactly, the network's time is reported, and a corrupt
// model file is a clear error naming it.
#include <gtest/gtest.h>

#include <fstream>

#include "obm/core/errors.hpp"
#include "obm/frontend/frontend.hpp"
#include "obm/obmnet/model_io.hpp"
#include "sim_loop.hpp"
#include "test_data.hpp"

namespace obm::frontend {
namespace {

std::string smallModel() {
  static const std::string path = [] {
    const std::string dir = test::scratchDir("frontend_obmnet");
    torch::manual_seed(3);
    obmnet::ObmNetConfig c;
    c.emb_dims = 16;
    c.n_samples = 8;
    c.n_iters = 1;
    c.n_keypoints = 64;
    obmnet::ObmNet net(c);
    obmnet::ModelMeta meta;
    meta.num_points = 512;
    meta.normalize_radius = 40.0;
    meta.description = "random test model";
    obmnet::saveModel(dir + "/lidar.pt", net, meta);
    return dir + "/lidar.pt";
  }();
  return path;
}

FrontendParams params(const std::string& model) {
  FrontendParams p;
  p.preprocess.max_range = 80.0;
  p.keyframes.distance = 4.0;
  p.local_map.keyframes = 10;
  p.tracking.max_correction_rotation = 12.0 * kDegToRad;
  p.loop_closure.min_travel = 60.0;
  p.loop_closure.check_every = 1;
  p.matcher.type = registration::MatcherKind::ObmNetIcp;
  p.matcher.obmnet.network.model_path = model;
  p.matcher.obmnet.network.threads = 1;
  p.matcher.obmnet.pre_align = true;
  p.matcher.obmnet.keep_init_if_better = true;
  p.matcher_fallback = registration::MatcherKind::Icp;
  p.matcher.icp.source_voxel = 0.5;
  p.matcher.icp.initial_max_correspondence_distance = 4.0;
  p.matcher.icp.max_iterations = 60;
  p.optimizer.init = backend::InitMethod::File;
  p.optimizer.num_threads = 1;
  return p;
}

TEST(FrontendObmNet, ExistingModelIsChosenAndVerifiesTheLoop) {
  const auto& loop = test::simLoop();
  const FrontendParams p = params(smallModel());
  const MatcherChoice choice = chooseMatcher(p);
  EXPECT_FALSE(choice.fell_back);
  EXPECT_EQ(choice.config.type, registration::MatcherKind::ObmNetIcp);
  Frontend fe(p);
  EXPECT_EQ(fe.matcherName(), "obmnet+icp");
  for (const auto& sweep : loop.sweeps) fe.process(sweep);
  fe.finish();
  ASSERT_GE(fe.stats().loops_accepted, 1u);
  for (const auto& lc : fe.loops()) {
    if (!lc.accepted) continue;
    const auto& kfs = fe.keyframes();
    const Isometry3d truth =
        loop.truth[kfs[lc.from].frame_index].inverse() * loop.truth[kfs[lc.to].frame_index];
    const auto [t, rot] = test::poseError(truth, lc.T_from_to);
    EXPECT_LT(t, 0.1);
    EXPECT_LT(rot, 0.3);
  }
  const auto& stages = fe.times().entries();
  ASSERT_TRUE(stages.count("obmnet"));
  EXPECT_GT(stages.at("obmnet").total_ms, 0.0);
  EXPECT_EQ(stages.count("loop_icp"), 0u);  // verification went through the network matcher
}

TEST(FrontendObmNet, CorruptModelIsAnErrorNamingTheFile) {
  const std::string dir = test::scratchDir("frontend_obmnet_bad");
  const std::string bad = dir + "/corrupt.pt";
  std::ofstream(bad) << "this is not a LibTorch archive";
  try {
    Frontend fe(params(bad));
    ADD_FAILURE() << "a corrupt model must not load";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("corrupt.pt"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace obm::frontend
