// Data-parallel training on loopback: two ranks as two threads of this process, each with its own
// c10d process group (rendezvous through a file), as two obm-train processes would run.
#include <gtest/gtest.h>
#include <torch/torch.h>

#include <cstdlib>
#include <filesystem>
#include <functional>
#include <random>
#include <thread>

#include "obm/core/errors.hpp"
#include "obm/obmnet/collectives.hpp"
#include "obm/obmnet/distributed.hpp"
#include "obm/obmnet/model_io.hpp"
#include "obm/obmnet/trainer.hpp"
#include "small_training.hpp"
#include "test_data.hpp"

using namespace obm;
using namespace obm::obmnet;

namespace {

/// Runs fn(rank, group) for two ranks in two threads; the groups meet through `store_file`.
/// An exception of either rank is rethrown here (rank 0's first).
void runTwoRanks(const std::string& store_file, double timeout_s,
                 const std::function<void(int, ProcessGroup&)>& fn) {
  std::filesystem::remove(store_file);
  std::exception_ptr errors[2];
  auto body = [&](int r) {
    try {
      DistributedOptions o;
      o.rank = r;
      o.world_size = 2;
      o.init_file = store_file;
      o.timeout_s = timeout_s;
      ProcessGroup g(o);
      fn(r, g);
    } catch (...) {
      errors[r] = std::current_exception();
    }
  };
  std::thread t1(body, 1);
  body(0);
  t1.join();
  for (auto& e : errors)
    if (e) std::rethrow_exception(e);
}

}  // namespace

TEST(Distributed, OptionsFromEnvironmentAreChecked) {
  setenv("WORLD_SIZE", "2", 1);
  setenv("RANK", "5", 1);
  try {
    (void)DistributedOptions::fromEnvironment();
    ADD_FAILURE() << "RANK outside [0, WORLD_SIZE) must be an error";
  } catch (const ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find("RANK=5"), std::string::npos) << e.what();
  }
  setenv("RANK", "1", 1);
  setenv("MASTER_PORT", "http", 1);
  EXPECT_THROW((void)DistributedOptions::fromEnvironment(), ConfigError);
  setenv("MASTER_PORT", "29611", 1);
  const auto o = DistributedOptions::fromEnvironment();
  EXPECT_EQ(o.rank, 1);
  EXPECT_EQ(o.world_size, 2);
  EXPECT_EQ(o.master_port, 29611);
  unsetenv("WORLD_SIZE");
  unsetenv("RANK");
  unsetenv("MASTER_PORT");
  const auto single = DistributedOptions::fromEnvironment();
  EXPECT_EQ(single.world_size, 1);
  EXPECT_EQ(single.rank, 0);
}

TEST(Distributed, GradientAllReduceEqualsOneStepOnTheUnionBatch) {
  // A model without batch normalisation, 8 pairs split 5 / 3 over two ranks (unequal shards: the
  // local_pairs / global_pairs weighting is what makes the sum the union mean). After the
  // all-reduce and one SGD step, both copies equal one process's step on all 8 pairs.
  torch::manual_seed(3);
  auto X = torch::randn({8, 3}), Y = torch::randn({8, 2});
  auto make = [] {
    torch::nn::Sequential m(torch::nn::Linear(3, 6), torch::nn::Tanh(), torch::nn::Linear(6, 2));
    return m;
  };
  torch::manual_seed(11);
  auto reference = make();
  std::vector<torch::nn::Sequential> copies;
  for (int r = 0; r < 2; ++r) {
    torch::manual_seed(static_cast<uint64_t>(100 + r));  // different initial weights on purpose
    copies.push_back(make());
  }
  const double lr = 0.1;
  {
    torch::optim::SGD opt(reference->parameters(), lr);
    opt.zero_grad();
    (reference->forward(X) - Y).pow(2).sum(1).mean().backward();
    opt.step();
  }
  // The copies start from the reference's initial weights: rank 0's, broadcast (rank 1's own
  // differ), as the trainer does at the start of a run.
  torch::manual_seed(11);
  auto initial = make();
  {
    torch::NoGradGuard ng;
    auto p0 = copies[0]->parameters();
    auto pi = initial->parameters();
    for (std::size_t i = 0; i < p0.size(); ++i) p0[i].copy_(pi[i]);
  }
  const std::string store = test::scratchDir("dist_union") + "/store";
  runTwoRanks(store, 60.0, [&](int r, ProcessGroup& g) {
    auto& m = copies[static_cast<std::size_t>(r)];
    broadcastTensors(g, m->parameters(), 0);
    torch::optim::SGD opt(m->parameters(), lr);
    opt.zero_grad();
    const auto x = r == 0 ? X.narrow(0, 0, 5) : X.narrow(0, 5, 3);
    const auto y = r == 0 ? Y.narrow(0, 0, 5) : Y.narrow(0, 5, 3);
    (m->forward(x) - y).pow(2).sum(1).mean().backward();
    allReduceGradients(g, m->parameters(), static_cast<int>(x.size(0)), 8);
    opt.step();
  });
  const auto pr = reference->parameters();
  for (int r = 0; r < 2; ++r) {
    const auto pc = copies[static_cast<std::size_t>(r)]->parameters();
    ASSERT_EQ(pc.size(), pr.size());
    for (std::size_t i = 0; i < pr.size(); ++i)
      EXPECT_TRUE(torch::allclose(pc[i], pr[i], 1e-5, 1e-6))
          << "rank " << r << ", parameter " << i << ": max difference "
          << (pc[i] - pr[i]).abs().max().item<double>();
  }
}

TEST(Distributed, BroadcastCopiesEveryDtypeFromTheRoot) {
  auto a0 = torch::arange(6, torch::kFloat32), b0 = torch::tensor({7, 8}, torch::kInt64);
  auto a1 = torch::zeros({6}), b1 = torch::zeros({2}, torch::kInt64);
  const std::string store = test::scratchDir("dist_bcast") + "/store";
  runTwoRanks(store, 60.0, [&](int r, ProcessGroup& g) {
    if (r == 0) broadcastTensors(g, {a0, b0}, 0);
    else broadcastTensors(g, {a1, b1}, 0);
  });
  EXPECT_TRUE(torch::equal(a1, a0));
  EXPECT_TRUE(torch::equal(b1, b0));
}

TEST(Distributed, APeerThatLeavesIsAClearError) {
  // Rank 1 joins and leaves (its process ended); rank 0's next collective must fail with an error
  // that names the rank, not hang.
  const std::string store = test::scratchDir("dist_leave") + "/store";
  try {
    runTwoRanks(store, 10.0, [&](int r, ProcessGroup& g) {
      if (r == 1) return;  // the group is destroyed: the connections close
      std::this_thread::sleep_for(std::chrono::milliseconds(200));
      std::vector<double> v{1.0};
      g.allReduceSum(v);
    });
    ADD_FAILURE() << "an all-reduce without its peer must throw";
  } catch (const obm::Error& e) {
    const std::string w = e.what();
    EXPECT_NE(w.find("rank 0 of 2"), std::string::npos) << w;
    EXPECT_NE(w.find("peer"), std::string::npos) << w;
  }
}

TEST(Distributed, TwoRanksTrainOneModelAndAnotherWorldSizeResumes) {
  // Two ranks of a small trainer: after an epoch their copies are identical (one model), they
  // moved, rank 0 alone wrote the run's files, and a single process resumes the run from them.
  TrainConfig tc = test::smallTrainConfig();
  tc.model.n_iters = 1;
  tc.val_pairs = 3;
  tc.pairs_per_epoch = 8;
  tc.epochs = 1;
  const std::vector<PointCloud> clouds = test::blobClouds(3, 150, 60);
  const std::string dir = test::scratchDir("dist_trainer");
  std::filesystem::remove_all(dir + "/run");
  // Built here, one after the other (the initial weights come from torch's global generator).
  Trainer t0(tc, clouds, clouds, dir + "/run"), t1(tc, clouds, clouds, dir + "/run");
  const auto initial = t0.parameterVector();
  std::vector<EpochStats> stats[2];
  Trainer* trainers[2] = {&t0, &t1};
  runTwoRanks(dir + "/store", 120.0, [&](int r, ProcessGroup& g) {
    // The group outlives the trainer's run; the trainer only borrows it.
    trainers[r]->setProcessGroup(std::shared_ptr<ProcessGroup>(&g, [](ProcessGroup*) {}));
    stats[r] = trainers[r]->run(false);
  });
  ASSERT_EQ(stats[0].size(), 1u);
  ASSERT_EQ(stats[1].size(), 1u);
  const auto p0 = t0.parameterVector(), p1 = t1.parameterVector();
  ASSERT_EQ(p0.size(), p1.size());
  EXPECT_EQ(p0, p1) << "the copies of a data-parallel run must stay identical";
  EXPECT_NE(p0, initial) << "the step changed nothing";
  // Both ranks report the same (reduced) losses and validation scores.
  EXPECT_DOUBLE_EQ(stats[0][0].loss, stats[1][0].loss);
  EXPECT_DOUBLE_EQ(stats[0][0].val_mie_r, stats[1][0].val_mie_r);
  for (const char* f : {"checkpoint.pt", "best.pt", "train_log.csv", "config.yaml"})
    EXPECT_TRUE(std::filesystem::exists(dir + "/run/" + f)) << f;
  // One process resumes the two-rank run for a second epoch, now keeping every epoch's model.
  tc.epochs = 2;
  tc.save_epochs = true;
  Trainer single(tc, clouds, clouds, dir + "/run");
  const auto s = single.run(true);
  ASSERT_EQ(s.size(), 1u);
  EXPECT_EQ(s[0].epoch, 2);
  EXPECT_FALSE(std::filesystem::exists(dir + "/run/epoch_001.pt")) << "epoch 1 ran without it";
  ModelMeta meta;
  ASSERT_NO_THROW(loadModel(dir + "/run/epoch_002.pt", &meta));
  EXPECT_EQ(meta.description.rfind("epoch 2,", 0), 0u) << meta.description;
  EXPECT_GT(s[0].comm_ms_per_step, -1.0);
  EXPECT_EQ(s[0].comm_ms_per_step, 0.0) << "a single process has no collectives";
}

TEST(Distributed, BatchSmallerThanTheWorldIsRejected) {
  TrainConfig tc;
  tc.batch_size = 1;
  tc.val_pairs = 1;
  tc.protocol.num_points = 64;
  tc.val_protocol = tc.protocol;
  tc.model.emb_dims = 16;
  PointCloud c;
  for (int i = 0; i < 80; ++i) c.points.emplace_back(0.01f * i, std::sin(0.3f * i), std::cos(0.7f * i));
  std::vector<PointCloud> clouds{c};
  Trainer t(tc, clouds, clouds, test::scratchDir("dist_small") + "/run");
  const std::string store = test::scratchDir("dist_small") + "/store";
  int rejected = 0;
  runTwoRanks(store, 30.0, [&](int r, ProcessGroup& g) {
    if (r == 0) {
      try {
        t.setProcessGroup(std::shared_ptr<ProcessGroup>(&g, [](ProcessGroup*) {}));
      } catch (const ConfigError& e) {
        ++rejected;
        EXPECT_NE(std::string(e.what()).find("batch_size"), std::string::npos) << e.what();
      }
    }
    // Both leave together: a rank that closes its connections while the other is still
    // finishing the rendezvous makes that one fail.
    g.barrier();
  });
  EXPECT_EQ(rejected, 1);
}
