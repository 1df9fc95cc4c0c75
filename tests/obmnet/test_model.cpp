// OBMNet: shapes, gradients, α > 0, weighted SVD, NMM equivalence, determinism, losses.
#include <gtest/gtest.h>
#include <torch/torch.h>

#include "obm/config/config_node.hpp"
#include "obm/core/errors.hpp"
#include "obm/obmnet/losses.hpp"
#include "obm/obmnet/model.hpp"
#include "obm/obmnet/nmm.hpp"
#include "obm/obmnet/svd.hpp"

using namespace obm;
using namespace obm::obmnet;

namespace {

obmnet::ObmNetConfig smallConfig() {
  obmnet::ObmNetConfig c;
  c.emb_dims = 32;
  c.dim = 4;
  c.k1 = 5;
  c.k2 = 4;
  c.n_keypoints = 16;
  c.n_samples = 8;
  c.n_iters = 2;
  c.seed = 3;
  return c;
}

/// A random rotation (QR of a Gaussian matrix, det fixed to +1), double.
torch::Tensor randomRotation(int64_t B) {
  auto A = torch::randn({B, 3, 3}, torch::kFloat64);
  auto [Q, R] = torch::linalg_qr(A);
  const auto d = torch::sign(torch::diagonal(R, 0, 1, 2));
  Q = Q * d.unsqueeze(1);
  const auto det = torch::det(Q);
  Q.select(2, 0).mul_(det.unsqueeze(1));
  return Q;
}

}  // namespace

TEST(ObmNet, OutputShapesAndAlphaPositive) {
  torch::manual_seed(0);
  obmnet::ObmNet net(smallConfig());
  const auto src = torch::randn({2, 3, 40});
  const auto tgt = torch::randn({2, 3, 36});
  net->train();
  const auto o = net->forward(src, tgt, true);
  EXPECT_EQ(o.R.sizes(), (std::vector<int64_t>{2, 3, 3}));
  EXPECT_EQ(o.t.sizes(), (std::vector<int64_t>{2, 3}));
  EXPECT_EQ(o.weights.sizes(), (std::vector<int64_t>{2, 40}));
  EXPECT_EQ(o.alpha.sizes(), (std::vector<int64_t>{2}));
  EXPECT_TRUE((o.alpha > 0).all().item<bool>());
  EXPECT_TRUE((o.weights > 0).all().item<bool>());
  EXPECT_TRUE((o.weights <= 1).all().item<bool>());
  EXPECT_TRUE((o.overlap > 0).all().item<bool>() && (o.overlap <= 1.0 + 1e-6).all().item<bool>());
  EXPECT_EQ(o.loss.dim(), 0);
  // R is a rotation.
  const auto RtR = torch::bmm(o.R.transpose(1, 2), o.R);
  EXPECT_TRUE(torch::allclose(RtR, torch::eye(3).expand({2, 3, 3}), 1e-4, 1e-4));
  EXPECT_NEAR(torch::det(o.R).min().item<double>(), 1.0, 1e-4);
}

TEST(ObmNet, GradientsReachEveryParameter) {
  torch::manual_seed(1);
  obmnet::ObmNet net(smallConfig());
  net->train();
  const auto src = torch::randn({2, 3, 48});
  const auto tgt = torch::randn({2, 3, 48});
  const auto o = net->forward(src, tgt, true);
  o.loss.backward();
  int n = 0;
  for (const auto& p : net->named_parameters()) {
    ASSERT_TRUE(p.value().grad().defined()) << p.key() << " gets no gradient";
    EXPECT_GT(p.value().grad().abs().sum().item<double>(), 0.0)
        << p.key() << " has a zero gradient";
    ++n;
  }
  EXPECT_GT(n, 20);
}

TEST(ObmNet, EvalIsDeterministicAndSeedMatters) {
  torch::manual_seed(2);
  obmnet::ObmNet a(smallConfig());
  a->eval();
  torch::NoGradGuard ng;
  const auto src = torch::randn({1, 3, 50});
  const auto tgt = torch::randn({1, 3, 50});
  const auto o1 = a->forward(src, tgt);
  const auto o2 = a->forward(src, tgt);
  EXPECT_TRUE(torch::equal(o1.R, o2.R));
  EXPECT_TRUE(torch::equal(o1.t, o2.t));
  EXPECT_TRUE(torch::equal(o1.membership, o2.membership));
  // The same weights with another Gumbel seed draw other overlap samples (hard draws at inference).
  auto cfg = smallConfig();
  cfg.seed = 99;
  torch::manual_seed(2);
  obmnet::ObmNet b(cfg);
  b->eval();
  const auto o3 = b->forward(src, tgt);
  EXPECT_FALSE(torch::equal(o1.R, o3.R));
}

namespace {

/// Batch-normalisation statistics away from their initial (0, 1), so that folding them into the
/// convolutions is exercised (fresh modules would fold to the identity).
void randomiseBatchNormStatistics(torch::nn::Module& m) {
  torch::NoGradGuard ng;
  for (auto& item : m.named_buffers()) {
    if (item.key().find("running_mean") != std::string::npos)
      item.value().copy_(torch::randn_like(item.value()));
    if (item.key().find("running_var") != std::string::npos)
      item.value().copy_(torch::rand_like(item.value()) * 2.0 + 0.1);
  }
  for (auto& item : m.named_parameters())
    if (item.value().dim() == 1) item.value().copy_(torch::randn_like(item.value()) * 0.5);
}

/// A random feature-distance map and two random clouds for the NMM tests (double).
struct NmmInputs {
  torch::Tensor M_feat, ps, pt;
  NmmInputs(int64_t B, int64_t N, int64_t M)
      : M_feat(torch::rand({B, N, M}, torch::kFloat64) * 3.0),
        ps(torch::randn({B, 3, N}, torch::kFloat64)),
        pt(torch::randn({B, 3, M}, torch::kFloat64)) {}
};

}  // namespace

TEST(Nmm, RefinedMatchingMapWithoutGradientEqualsTheGraph) {
  // refinedMatchingMap without gradient (float, CPU: the row kernels) against the tensor graph in
  // double, with NMM and without; B = 2, N ≠ M, neither a multiple of the kernels' row block,
  // k_s ≠ k_t.
  torch::manual_seed(13);
  const int64_t B = 2, D = 16, N = 37, M = 45;
  // Features far apart (scale 2), so that the matching maps are peaked.
  const auto fp = torch::randn({B, D, N}) * 2.0;
  const auto fq = torch::randn({B, D, M}) * 2.0;
  const auto src_idx = obmnet::knnIndices(torch::randn({B, 3, N}), torch::randn({B, 3, N}), 4);
  const auto tgt_idx = obmnet::knnIndices(torch::randn({B, 3, M}), torch::randn({B, 3, M}), 3);
  const obmnet::NmmParams params{0.7, 1e-6};
  const auto M_feat =
      (obmnet::pairwiseSquaredDistance(fp.to(torch::kFloat64), fq.to(torch::kFloat64)) + 1e-12)
          .sqrt();
  // S is small by construction (D is normalised over the row), but its effect on M^r (against
  // S = 0, i.e. M^e = e^γ·M) must be well above the tolerance below, or the comparison would not
  // see a wrong S.
  const auto s_effect = (obmnet::nmm(M_feat, src_idx, tgt_idx, params) -
                         torch::softmax(-std::exp(params.gamma) * M_feat, 2))
                            .abs()
                            .max();
  ASSERT_GT(s_effect.item<double>(), 5e-4);
  for (const bool use_nmm : {true, false}) {
    const auto reference =
        use_nmm ? obmnet::nmm(M_feat, src_idx, tgt_idx, params) : torch::softmax(-M_feat, 2);
    torch::NoGradGuard ng;
    const auto kernel = obmnet::refinedMatchingMap(fp, fq, src_idx, tgt_idx, params, use_nmm);
    ASSERT_EQ(kernel.sizes(), reference.sizes());
    EXPECT_TRUE(torch::allclose(kernel.to(torch::kFloat64), reference, 1e-4, 1e-7))
        << "NMM " << use_nmm << ", max difference "
        << (kernel.to(torch::kFloat64) - reference).abs().max().item<double>();
  }
  // With the spatial prior (σ = 0.5 on unit-scale points, strong enough to move M^r by far more
  // than the tolerance): the final logits get −‖p_i − q_j‖²/(2σ²), M′ and S stay the features'.
  const auto pts_p = torch::randn({B, 3, N});
  const auto pts_q = torch::randn({B, 3, M});
  const double sigma = 0.5;
  const auto prior_cost = obmnet::pairwiseSquaredDistance(pts_p.to(torch::kFloat64),
                                                          pts_q.to(torch::kFloat64)) /
                          (2.0 * sigma * sigma);
  for (const bool use_nmm : {true, false}) {
    const auto cost = use_nmm ? obmnet::nmmEnhancedCost(M_feat, src_idx, tgt_idx, params) : M_feat;
    const auto reference = torch::softmax(-(cost + prior_cost), 2);
    ASSERT_GT((reference - torch::softmax(-cost, 2)).abs().max().item<double>(), 0.1);
    torch::NoGradGuard ng;
    const auto kernel = obmnet::refinedMatchingMap(fp, fq, src_idx, tgt_idx, params, use_nmm,
                                                   sigma, pts_p, pts_q);
    EXPECT_TRUE(torch::allclose(kernel.to(torch::kFloat64), reference, 1e-4, 1e-7))
        << "prior, NMM " << use_nmm << ", max difference "
        << (kernel.to(torch::kFloat64) - reference).abs().max().item<double>();
    // The graph form (with gradient) computes the same map.
    torch::AutoGradMode grad(true);
    const auto graph = obmnet::refinedMatchingMap(fp.to(torch::kFloat64).requires_grad_(),
                                                  fq.to(torch::kFloat64), src_idx, tgt_idx,
                                                  params, use_nmm, sigma,
                                                  pts_p.to(torch::kFloat64),
                                                  pts_q.to(torch::kFloat64));
    EXPECT_TRUE(torch::allclose(graph.detach(), reference, 1e-9, 1e-12))
        << "graph, NMM " << use_nmm;
  }
  // The kernels read M′ at the neighbour indices: one outside the cloud is refused, not read.
  torch::NoGradGuard ng;
  auto bad = tgt_idx.clone();
  bad[1][3][2] = M;
  EXPECT_THROW(obmnet::refinedMatchingMap(fp, fq, src_idx, bad, params), ContractError);
}

TEST(InlierEvaluator, InferenceWithoutGradientEqualsTheGraph) {
  // Eval mode without gradient folds batch normalisation into the convolutions and evaluates
  // both clouds' edges in one block; with gradients it runs the training graph. Same weights.
  torch::manual_seed(14);
  // Statistics near the identity: the fully random ones of randomiseBatchNormStatistics saturate
  // the score (w = 1 − tanh|s| = 0 everywhere), which would hide any difference.
  const auto mildStatistics = [](torch::nn::Module& m) {
    torch::NoGradGuard ng;
    for (auto& item : m.named_buffers()) {
      if (item.key().find("running_mean") != std::string::npos)
        item.value().copy_(0.1 * torch::randn_like(item.value()));
      if (item.key().find("running_var") != std::string::npos)
        item.value().copy_(torch::rand_like(item.value()) + 0.5);
    }
    for (auto& item : m.named_parameters()) {
      if (item.value().dim() == 1 && item.key().find("weight") != std::string::npos)
        item.value().copy_(1.0 + 0.2 * torch::randn_like(item.value()));
      // A larger last score layer without offset: an untrained score barely varies over the
      // points.
      if (item.key() == "score.6.weight") item.value().mul_(30.0);
      if (item.key() == "score.6.bias") item.value().zero_();
    }
  };
  for (int64_t k : {5, 32}) {
    obmnet::InlierEvaluator inlier(8);
    mildStatistics(*inlier);
    inlier->eval();
    const auto src = torch::randn({2, 3, 70});
    // The pseudo-targets: the source moved a little, so that the weights spread over (0, 1).
    const auto pseudo = src + 0.3 * torch::randn({2, 3, 70});
    const auto idx = obmnet::knnIndices(src, src, k);
    const auto graph = inlier->forward(src, pseudo, idx).detach();
    ASSERT_GT((graph.amax(1) - graph.amin(1)).min().item<float>(), 0.01f)
        << "weights too uniform to test, k = " << k;
    torch::NoGradGuard ng;
    const auto fused = inlier->forward(src, pseudo, idx);
    EXPECT_TRUE(torch::allclose(fused, graph, 1e-4, 1e-6))
        << "k = " << k << ", max difference " << (fused - graph).abs().max().item<float>();
    // Folded once and kept: new statistics must be folded again.
    mildStatistics(*inlier);
    const auto refused = inlier->forward(src, pseudo, idx);
    torch::GradMode::set_enabled(true);
    const auto regraph = inlier->forward(src, pseudo, idx).detach();
    torch::GradMode::set_enabled(false);
    EXPECT_TRUE(torch::allclose(refused, regraph, 1e-4, 1e-6))
        << "k = " << k << ", after new statistics, max difference "
        << (refused - regraph).abs().max().item<float>();
  }
}

TEST(DenseEdgeConv, FusedInferenceEqualsTheLayeredPath) {
  torch::manual_seed(5);
  for (const bool with_normals : {false, true}) {
    for (int64_t k : {5, 32}) {
      obmnet::DenseEdgeConv conv(
          k, 48, with_normals ? obmnet::EdgeFeatures::Normals : obmnet::EdgeFeatures::Offsets);
      randomiseBatchNormStatistics(*conv);
      conv->eval();
      const auto x = torch::randn({3, 3, 70});
      const auto idx = knnIndices(x, x, k);
      const auto n = with_normals ? orientedNormals(x, idx) : torch::Tensor();
      torch::NoGradGuard ng;
      const auto fused = conv->forward(x, idx, n);  // eval, no gradient: the fused path
      const auto layered = conv->forwardLayered(x, idx, n);
      ASSERT_EQ(fused.sizes(), layered.sizes());
      EXPECT_GT(layered.abs().max().item<float>(), 0.1f);
      EXPECT_TRUE(torch::allclose(fused, layered, 1e-4, 1e-5))
          << "normals " << with_normals << ", k = " << k << ", max difference "
          << (fused - layered).abs().max().item<float>();
      // The folded layers are kept between calls; weights changed in place (as by an optimiser
      // step or a model load) must be folded again.
      randomiseBatchNormStatistics(*conv);
      const auto refused = conv->forward(x, idx, n);
      const auto relayered = conv->forwardLayered(x, idx, n);
      EXPECT_FALSE(torch::allclose(relayered, layered, 1e-2, 1e-3));
      EXPECT_TRUE(torch::allclose(refused, relayered, 1e-4, 1e-5))
          << "normals " << with_normals << ", k = " << k << ", after new weights, max difference "
          << (refused - relayered).abs().max().item<float>();
      if (with_normals) {
        // The normal channels count: other normals, other features.
        const auto flipped = conv->forward(x, idx, -n);
        EXPECT_FALSE(torch::allclose(flipped, refused, 1e-3, 1e-4));
      }
    }
  }
}

TEST(DenseEdgeConv, OrientedNormalsPointOutOfASphereAndTurnWithIt) {
  // 400 random points on a sphere of radius 2 about (1, −1, 3).
  torch::manual_seed(9);
  auto dirs = torch::randn({1, 3, 400});
  dirs = dirs / dirs.norm(2, 1, true);
  const auto centre = torch::tensor({1.0f, -1.0f, 3.0f}).view({1, 3, 1});
  const auto x = centre + 2.0 * dirs;
  const auto n = orientedNormals(x, knnIndices(x, x, 16));
  ASSERT_EQ(n.sizes(), x.sizes());
  EXPECT_TRUE(torch::allclose(n.norm(2, 1), torch::ones({1, 400}), 1e-4, 1e-5));
  // Outward: cos(n, radial direction) close to +1 at every point, not merely in magnitude.
  EXPECT_GT((n * dirs).sum(1).min().item<float>(), 0.95f);
  // A rigid motion turns them: n(R·x + t) = R·n(x) (same neighbourhoods, same sign rule).
  const auto R = torch::tensor({0.36f, 0.48f, -0.8f, -0.8f, 0.6f, 0.0f, 0.48f, 0.64f, 0.6f})
                     .view({1, 3, 3});
  const auto y = torch::bmm(R, x) + torch::tensor({5.0f, 0.0f, -2.0f}).view({1, 3, 1});
  const auto ny = orientedNormals(y, knnIndices(x, x, 16));
  EXPECT_LT((ny - torch::bmm(R, n)).abs().max().item<float>(), 1e-3f);
}

TEST(ObmNet, InferenceWithoutGradientsEqualsTheTrainingGraphInEvalMode) {
  // Eval mode without gradients takes the fused extractor and the row-wise matching kernel; with
  // gradients enabled it runs the layer-by-layer graph of training. The two must give the same
  // pose, with neighbour map matching and without, on sizes that are not a multiple of the
  // kernel's row block; and with edge normals.
  for (const auto& [use_nmm, edge_normals] :
       std::vector<std::pair<bool, bool>>{{true, false}, {false, false}, {true, true}}) {
    torch::manual_seed(6);
    auto cfg = smallConfig();
    cfg.k1 = 8;
    cfg.use_nmm = use_nmm;
    cfg.edge_normals = edge_normals;
    cfg.normal_neighbours = 6;
    obmnet::ObmNet net(cfg);
    randomiseBatchNormStatistics(*net);
    net->eval();
    const auto src = torch::randn({2, 3, 60});
    const auto tgt = torch::randn({2, 3, 64});
    const auto with_graph = net->forward(src, tgt);
    obmnet::ObmNetOutput fused;
    {
      torch::NoGradGuard ng;
      fused = net->forward(src, tgt);
    }
    // Float rounding differs between the two paths (and between CPUs' vector units); three SVD
    // iterations on random clouds magnify it to ~1.5e-4 in R on some machines. A missing or wrong
    // term moves R by orders of magnitude more.
    EXPECT_TRUE(torch::allclose(fused.R, with_graph.R.detach(), 1e-3, 5e-4))
        << "NMM " << use_nmm << ", max difference "
        << (fused.R - with_graph.R).abs().max().item<float>();
    EXPECT_TRUE(torch::allclose(fused.t, with_graph.t.detach(), 1e-3, 5e-4)) << "NMM " << use_nmm;
    EXPECT_TRUE(torch::allclose(fused.weights, with_graph.weights.detach(), 1e-3, 1e-4))
        << "NMM " << use_nmm;
    // The best candidates of the last matching map, wherever the best is not tied with the second
    // best to rounding (within 1e-4 of its probability: a tie may fall either way; the maps of
    // this small random network are nearly flat, gaps of ~1e-6 occur), and that is most rows.
    const auto top2 = with_graph.match_prob.detach();
    const auto clear = (top2.select(2, 0) - top2.select(2, 1)) > 1e-4 * top2.select(2, 0);
    const auto same = fused.match_index.select(2, 0) == with_graph.match_index.select(2, 0);
    EXPECT_GE(clear.to(torch::kFloat).mean().item<float>(), 0.9f) << "NMM " << use_nmm;
    EXPECT_TRUE(torch::logical_or(same, clear.logical_not()).all().item<bool>())
        << "NMM " << use_nmm << ": a clear best candidate differs";
    EXPECT_TRUE(torch::allclose(fused.match_prob, with_graph.match_prob.detach(), 1e-3, 1e-5))
        << "NMM " << use_nmm << ", max difference "
        << (fused.match_prob - with_graph.match_prob).abs().max().item<float>();
  }
}

TEST(Knn, SortedNeighboursEqualAFullSortOfTheDistances) {
  // knnIndices: the k nearest reference points, nearest first, for every query point. Checked
  // against a double-precision sort of all distances (by distance at each rank, so that equal
  // distances may come in either order), query ≠ reference, B = 2, k up to every point.
  torch::manual_seed(12);
  const auto query = torch::randn({2, 3, 50});
  auto ref = torch::randn({2, 3, 70});
  ref.select(2, 9).copy_(ref.select(2, 3));  // a duplicate point: two equal distances everywhere
  const auto d =
      obmnet::pairwiseSquaredDistance(query.to(torch::kFloat64), ref.to(torch::kFloat64));
  const auto sorted = std::get<0>(d.sort(2));
  for (int64_t k : {1, 7, 32, 70}) {
    const auto idx = obmnet::knnIndices(query, ref, k);
    ASSERT_EQ(idx.sizes(), (std::vector<int64_t>{2, 50, k}));
    ASSERT_EQ(idx.scalar_type(), torch::kLong);
    const auto picked = d.gather(2, idx);
    EXPECT_TRUE(torch::allclose(picked, sorted.narrow(2, 0, k), 1e-9, 1e-5))
        << "k = " << k << ", max difference "
        << (picked - sorted.narrow(2, 0, k)).abs().max().item<double>();
    // Each reference point at most once per row.
    const auto uniq = std::get<0>(idx.sort(2));
    EXPECT_TRUE((uniq.narrow(2, 1, k - 1) != uniq.narrow(2, 0, k - 1)).all().item<bool>() ||
                k == 1);
  }
  // A cloud against itself: every point is its own nearest neighbour.
  const auto self = obmnet::knnIndices(query, query, 5).select(2, 0);
  EXPECT_TRUE(torch::equal(self, torch::arange(50).expand({2, 50})));
}

TEST(ObmNet, TrainingIsDeterministicUnderAFixedSeed) {
  auto run = [] {
    torch::manual_seed(7);
    obmnet::ObmNet net(smallConfig());
    net->train();
    torch::manual_seed(8);
    const auto src = torch::randn({2, 3, 32});
    const auto tgt = torch::randn({2, 3, 32});
    return net->forward(src, tgt, true).loss.item<double>();
  };
  EXPECT_EQ(run(), run());
}

TEST(ObmNet, AblationSwitchesBuildAndRun) {
  for (int mask = 0; mask < 8; ++mask) {
    auto c = smallConfig();
    c.use_overlap_sampling = mask & 1;
    c.use_bias_prediction = (mask & 2) && c.use_overlap_sampling;
    c.use_nmm = mask & 4;
    obmnet::ObmNet net(c);
    net->train();
    const auto o = net->forward(torch::randn({2, 3, 24}), torch::randn({2, 3, 24}), true);
    EXPECT_TRUE(std::isfinite(o.loss.item<double>())) << "mask " << mask;
    if (!c.use_bias_prediction) {
      EXPECT_TRUE(torch::all(o.alpha == 1).item<bool>());
    }
  }
  auto bad = smallConfig();
  bad.use_overlap_sampling = false;
  bad.use_bias_prediction = true;
  EXPECT_THROW(obmnet::ObmNet{bad}, ConfigError);
}

TEST(ObmNet, RejectsMalformedInput) {
  obmnet::ObmNet net(smallConfig());
  EXPECT_THROW(net->forward(torch::randn({1, 2, 30}), torch::randn({1, 3, 30})), ContractError);
  EXPECT_THROW(net->forward(torch::randn({1, 3, 3}), torch::randn({1, 3, 30})), ContractError);
}

TEST(WeightedSvd, ExactOnNoiseFreeCorrespondences) {
  torch::manual_seed(4);
  const int64_t B = 3, N = 50;
  const auto R = randomRotation(B);
  const auto t = torch::randn({B, 3}, torch::kFloat64);
  const auto x = torch::randn({B, 3, N}, torch::kFloat64);
  const auto y = torch::bmm(R, x) + t.unsqueeze(2);
  const auto w = torch::rand({B, N}, torch::kFloat64) + 0.1;
  const auto T = weightedProcrustes(x, y, w);
  EXPECT_TRUE(torch::allclose(T.R, R, 1e-9, 1e-9));
  EXPECT_TRUE(torch::allclose(T.t, t, 1e-9, 1e-9));
}

TEST(WeightedSvd, ZeroWeightIgnoresOutliers) {
  torch::manual_seed(5);
  const auto R = randomRotation(1);
  const auto t = torch::randn({1, 3}, torch::kFloat64);
  const auto x = torch::randn({1, 3, 40}, torch::kFloat64);
  auto y = torch::bmm(R, x) + t.unsqueeze(2);
  auto w = torch::ones({1, 40}, torch::kFloat64);
  // Corrupt 10 correspondences and give them weight 0: the result stays exact.
  y.narrow(2, 0, 10).add_(torch::randn({1, 3, 10}, torch::kFloat64) * 5.0);
  w.narrow(1, 0, 10).zero_();
  const auto T = weightedProcrustes(x, y, w);
  EXPECT_TRUE(torch::allclose(T.R, R, 1e-9, 1e-9));
  // With uniform weights the corrupted points pull it off.
  const auto T2 = weightedProcrustes(x, y, torch::ones({1, 40}, torch::kFloat64));
  EXPECT_FALSE(torch::allclose(T2.R, R, 1e-3, 1e-3));
}

TEST(WeightedSvd, NeverReturnsAReflection) {
  // y is a mirror image of x: the best orthogonal map is a reflection; the result must be proper.
  torch::manual_seed(6);
  const auto x = torch::randn({1, 3, 30}, torch::kFloat64);
  auto y = x.clone();
  y.select(1, 2).neg_();
  const auto T = weightedProcrustes(x, y, torch::ones({1, 30}, torch::kFloat64));
  EXPECT_NEAR(torch::det(T.R).item<double>(), 1.0, 1e-9);
}

TEST(Nmm, FastFormEqualsLiteralGather) {
  torch::manual_seed(9);
  const int64_t B = 2, N = 13;
  const NmmInputs in(B, N, 11);
  const auto& [M_feat, ps, pt] = in;
  for (int64_t k : {1, 3, 5}) {
    const auto si = knnIndices(ps, ps, k);
    const auto ti = knnIndices(pt, pt, k);
    const NmmParams p{0.6, 1e-6};
    const auto fast = nmmEnhancedCost(M_feat, si, ti, p);
    const auto slow = nmmEnhancedCostLiteral(M_feat, si, ti, p);
    EXPECT_TRUE(torch::allclose(fast, slow, 1e-10, 1e-12)) << "k = " << k;
  }
  // Different neighbourhood sizes on the two sides.
  const auto si = knnIndices(ps, ps, 4);
  const auto ti = knnIndices(pt, pt, 2);
  EXPECT_TRUE(torch::allclose(nmmEnhancedCost(M_feat, si, ti, {}),
                              nmmEnhancedCostLiteral(M_feat, si, ti, {}), 1e-10, 1e-12));
  // M^r is row-stochastic.
  const auto Mr = nmm(M_feat, si, ti, {});
  EXPECT_TRUE(torch::allclose(Mr.sum(2), torch::ones({B, N}, torch::kFloat64), 1e-12, 1e-12));
}

TEST(Nmm, InferenceKernelsEqualTheLiteralGather) {
  // Float without autograd takes the raw-loop kernels (row sums of M′ and M′² over the source
  // neighbours, then over the target neighbours on the transpose); they must agree with the
  // literal gather of the definition.
  torch::manual_seed(10);
  const NmmInputs in(2, 37, 29);
  const auto& [M_feat, ps, pt] = in;
  const auto si = knnIndices(ps, ps, 6);
  const auto ti = knnIndices(pt, pt, 4);
  const NmmParams p{0.7, 1e-6};
  const auto literal = nmmEnhancedCostLiteral(M_feat, si, ti, p).to(torch::kFloat32);
  torch::NoGradGuard ng;
  const auto fast = nmmEnhancedCost(M_feat.to(torch::kFloat32), si, ti, p);
  EXPECT_TRUE(torch::allclose(fast, literal, 1e-4, 1e-6))
      << "max difference " << (fast - literal).abs().max().item<float>();
  // One batch element alone gives the same as inside the batch.
  const auto one = nmmEnhancedCost(M_feat.to(torch::kFloat32).narrow(0, 1, 1), si.narrow(0, 1, 1),
                                   ti.narrow(0, 1, 1), p);
  EXPECT_TRUE(torch::allclose(one, fast.narrow(0, 1, 1), 1e-5, 1e-7));
}

TEST(Knn, SelfFirstAndSorted) {
  const auto x = torch::tensor({0.0, 1.0, 3.0, 7.0}, torch::kFloat32)
                     .view({1, 1, 4})
                     .expand({1, 3, 4})
                     .contiguous();
  const auto idx = knnIndices(x, x, 3);
  EXPECT_EQ(idx[0][0][0].item<int64_t>(), 0);
  EXPECT_EQ(idx[0][0][1].item<int64_t>(), 1);
  EXPECT_EQ(idx[0][0][2].item<int64_t>(), 2);
  EXPECT_EQ(idx[0][3][1].item<int64_t>(), 2);
}

TEST(Losses, HuberIsContinuousAndQuadraticBelowMargin) {
  const double c = 0.01;
  const auto x = torch::tensor({0.0, 0.005, c - 1e-9, c, 0.02}, torch::kFloat64);
  const auto h = huber(x, c);
  EXPECT_DOUBLE_EQ(h[1].item<double>(), 0.5 * 0.005 * 0.005);
  EXPECT_NEAR(h[2].item<double>(), h[3].item<double>(), 1e-10);
  EXPECT_DOUBLE_EQ(h[4].item<double>(), c * 0.02 - 0.5 * c * c);
}

TEST(Losses, GlobalAlignmentZeroWhenAligned) {
  torch::manual_seed(10);
  const auto x = torch::randn({2, 3, 30});
  EXPECT_NEAR(globalAlignmentLoss(x, x, 0.01).item<double>(), 0.0, 1e-10);
  EXPECT_GT(globalAlignmentLoss(x + 0.3, x, 0.01).item<double>(), 1e-4);
}

TEST(Losses, NeighborhoodZeroForExactRigidMotion) {
  torch::manual_seed(11);
  const auto R = randomRotation(1).to(torch::kFloat32);
  const auto t = torch::randn({1, 3});
  const auto src = torch::randn({1, 3, 40});
  const auto tgt = torch::bmm(R, src) + t.unsqueeze(2);
  const RigidTransforms T{R, t};
  const auto kp = torch::arange(10, torch::kInt64).unsqueeze(0);
  EXPECT_NEAR(neighborhoodLoss(src, tgt, tgt, T, kp, 5).item<double>(), 0.0, 1e-4);
  const RigidTransforms I = identityTransforms(1, src.options());
  EXPECT_GT(neighborhoodLoss(src, tgt, tgt, I, kp, 5).item<double>(), 0.1);
}

TEST(Losses, SpatialConsistencyIsMinusLogOfRowMax) {
  auto P = torch::tensor({{0.7, 0.2, 0.1}, {0.1, 0.1, 0.8}}, torch::kFloat64).unsqueeze(0);
  const auto kp = torch::tensor({0, 1}, torch::kInt64).unsqueeze(0);
  const double expected = -(std::log(0.7) + std::log(0.8)) / 2.0;
  EXPECT_NEAR(spatialConsistencyLoss(P.log(), kp).item<double>(), expected, 1e-12);
}

TEST(Losses, PoseLabelIsTheMeanPointDistance) {
  torch::manual_seed(13);
  const auto src = torch::randn({2, 3, 25});
  const auto R = randomRotation(2).to(torch::kFloat32);
  const auto t = torch::randn({2, 3});
  EXPECT_NEAR(poseLabelLoss(R, t, R, t, src).item<double>(), 0.0, 1e-5);
  // A pure translation error moves every point by its norm: the loss is that norm.
  const auto dt = torch::tensor({{0.3f, 0.f, 0.4f}, {0.f, 0.f, 0.5f}});
  EXPECT_NEAR(poseLabelLoss(R, t + dt, R, t, src).item<double>(), 0.5, 1e-5);
  // Its gradient pulls the estimate towards the label.
  auto t_hat = (t + dt).clone().requires_grad_(true);
  poseLabelLoss(R, t_hat, R, t, src).backward();
  EXPECT_GT((t_hat.grad() * dt).sum().item<double>(), 0.0);
}

TEST(WeightedSvd, VanishedWeightsFallBackToUniform) {
  torch::manual_seed(12);
  const auto R = randomRotation(1);
  const auto x = torch::randn({1, 3, 20}, torch::kFloat64);
  const auto y = torch::bmm(R, x);
  const auto T = weightedProcrustes(x, y, torch::zeros({1, 20}, torch::kFloat64));
  EXPECT_TRUE(torch::allclose(T.R, R, 1e-9, 1e-9));
}

TEST(ObmNet, SoftInferenceSamplingIsRepeatableRecordedAndNotTheOneHotDraw) {
  torch::manual_seed(5);
  obmnet::ObmNet net(smallConfig());
  const auto src = torch::randn({1, 3, 48});
  const auto tgt = torch::randn({1, 3, 48});
  // A few train-mode passes so that the batch-norm running statistics are not the defaults.
  net->train();
  for (int i = 0; i < 3; ++i) net->forward(src, tgt, false);
  net->eval();
  torch::NoGradGuard ng;
  const auto hard = net->forward(src, tgt, false);
  net->setSoftInferenceSampling(true);
  const auto soft1 = net->forward(src, tgt, false);
  const auto soft2 = net->forward(src, tgt, false);
  // The same pair gives the same result (the eval noise stream is re-seeded), and the relaxed
  // draws are not the one-hot ones: the sampled overlap, and with it α, differ.
  EXPECT_TRUE(torch::equal(soft1.R, soft2.R));
  EXPECT_TRUE(torch::equal(soft1.alpha, soft2.alpha));
  EXPECT_FALSE(torch::equal(soft1.alpha, hard.alpha));
  net->setSoftInferenceSampling(false);
  EXPECT_TRUE(torch::equal(net->forward(src, tgt, false).alpha, hard.alpha));
  // Recorded with the weights: the key round-trips through the model file's YAML.
  obmnet::ObmNetConfig c = smallConfig();
  c.soft_inference_sampling = true;
  const auto back = obmnet::ObmNetConfig::load(ConfigNode::fromString(c.toYaml()));
  EXPECT_TRUE(back.soft_inference_sampling);
  EXPECT_EQ(smallConfig().toYaml().find("soft_inference_sampling"), std::string::npos)
      << "models trained without the key keep their embedded text";
}

TEST(ObmNet, SpatialPriorCorrectsASmallMotionAsIcpWouldAndIsRecorded) {
  // Two independent samplings (300 points each) of an ellipsoid's surface (semi-axes 0.5, 0.35,
  // 0.2), the source moved by 3° and 0.03: an untrained network matches by random features that
  // differ between the two samplings; with a prior of σ = 0.03 around each source point its soft
  // correspondences are the nearby points, and the iterations close the motion as ICP steps would.
  torch::manual_seed(11);
  obmnet::ObmNetConfig c = smallConfig();
  c.n_iters = 3;
  obmnet::ObmNet net(c);
  net->eval();
  torch::NoGradGuard ng;
  auto ellipsoid = [](int64_t n) {
    auto d = torch::randn({3, n}, torch::kFloat64);
    d = d / d.norm(2, 0, true);
    return d * torch::tensor({0.5, 0.35, 0.2}, torch::kFloat64).unsqueeze(1);
  };
  const auto tgt64 = ellipsoid(300);
  auto axis = torch::randn({3}, torch::kFloat64);
  axis = axis / axis.norm();
  const double angle = 3.0 * M_PI / 180.0;
  // R_ts = exp(angle·[axis]×) (Rodrigues), t_ts = 0.03 along y: tgt = R_ts·src + t_ts.
  auto K = torch::zeros({3, 3}, torch::kFloat64);
  K[0][1] = -axis[2];
  K[0][2] = axis[1];
  K[1][0] = axis[2];
  K[1][2] = -axis[0];
  K[2][0] = -axis[1];
  K[2][1] = axis[0];
  const auto R_ts = torch::eye(3, torch::kFloat64) + std::sin(angle) * K +
                    (1.0 - std::cos(angle)) * torch::mm(K, K);
  const auto t_ts = torch::tensor({0.0, 0.03, 0.0}, torch::kFloat64);
  const auto src64 = torch::mm(R_ts.t(), ellipsoid(300) - t_ts.unsqueeze(1));
  const auto src = src64.unsqueeze(0).to(torch::kFloat32);
  const auto tgt = tgt64.unsqueeze(0).to(torch::kFloat32);
  auto errors = [&](const obmnet::ObmNetOutput& o) {
    const auto dR = torch::mm(o.R[0].to(torch::kFloat64).t(), R_ts);
    const double c_angle = std::clamp((dR.trace().item<double>() - 1.0) / 2.0, -1.0, 1.0);
    return std::make_pair(std::acos(c_angle) * 180.0 / M_PI,
                          (o.t[0].to(torch::kFloat64) - t_ts).norm().item<double>());
  };
  const auto [rre_free, rte_free] = errors(net->forward(src, tgt));
  net->setSpatialPrior(0.03);
  const auto [rre_prior, rte_prior] = errors(net->forward(src, tgt));
  std::printf(
      "untrained network: without the prior %.2f deg / %.4f, with the prior %.2f deg / %.4f\n",
      rre_free, rte_free, rre_prior, rte_prior);
  // The prior's estimate is closer than the start (3°, 0.03) in both; without it the untrained
  // features throw the pose far beyond the start.
  EXPECT_LT(rre_prior, 3.0);
  EXPECT_LT(rte_prior, 0.01);  // a third of the start's
  EXPECT_GT(rre_free, 3.0);
  // Recorded with the weights, and refused when negative (naming the key).
  c.match_spatial_sigma = 0.1;
  EXPECT_DOUBLE_EQ(
      obmnet::ObmNetConfig::load(ConfigNode::fromString(c.toYaml())).match_spatial_sigma, 0.1);
  EXPECT_EQ(smallConfig().toYaml().find("match_spatial_sigma"), std::string::npos)
      << "models trained without the key keep their embedded text";
  try {
    obmnet::ObmNetConfig::load(ConfigNode::fromString("match_spatial_sigma: -0.1\n"));
    FAIL() << "a negative σ was accepted";
  } catch (const ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find("match_spatial_sigma"), std::string::npos) << e.what();
  }
}
