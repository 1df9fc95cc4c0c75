#include "obm/obmnet/model.hpp"

#include "obm/core/errors.hpp"
#include "obm/obmnet/losses.hpp"
#include "obm/obmnet/nmm.hpp"
#include "obm/obmnet/svd.hpp"

namespace obm::obmnet {

namespace nn = torch::nn;
using obmnet::RigidTransforms;

ObmNetImpl::ObmNetImpl(const ObmNetConfig& config) : config_(config) {
  config_.validate();
  extractor_ = register_module(
      "extractor",
      obmnet::DenseEdgeConv(config_.k1, config_.emb_dims,
                            config_.edge_normals ? obmnet::EdgeFeatures::Normals
                                                 : obmnet::EdgeFeatures::Offsets));
  if (config_.use_overlap_sampling) {
    sampler_ = register_module(
        "sampler", obmnet::OverlapSampler(config_.emb_dims, config_.n_samples, config_.tau_min));
    sampler_->setSoftInference(config_.soft_inference_sampling);
    // Fusion of a point's feature with the overlap representations of both clouds (own, other):
    // Φ' = Φ + conv([Φ; T_self; T_other]). The residual form keeps Φ itself as the matching
    // feature at initialisation and lets training add the overlap context.
    overlap_fusion_ = register_module(
        "overlap_fusion",
        nn::Conv1d(nn::Conv1dOptions(3 * config_.emb_dims, config_.emb_dims, 1).bias(false)));
  }
  if (config_.use_bias_prediction) bias_ = register_module("bias", obmnet::BiasPredictor());
  inlier_ = register_module("inlier", obmnet::InlierEvaluator(config_.dim));
  train_gen_ = at::make_generator<at::CPUGeneratorImpl>(config_.seed);
}

namespace {

/// W_Φ·Φ, the per-point share of the overlap fusion conv([Φ; T_self; T_other]) (step 4).
torch::Tensor fusionProjection(torch::nn::Conv1d& fusion, const torch::Tensor& phi) {
  const int64_t D = phi.size(1);
  OBM_ASSERT(!fusion->bias.defined() && fusion->weight.size(1) == 3 * D,
             "ObmNet: the overlap fusion must be a bias-free Conv1d over 3D channels");
  return torch::matmul(fusion->weight.squeeze(2).narrow(1, 0, D), phi);
}

/// Φ' of the matching map: the features fused with the overlap representations (step 4), from
/// `projected` = fusionProjection(fusion, phi).
torch::Tensor fuse(torch::nn::Conv1d& fusion, const torch::Tensor& phi,
                   const torch::Tensor& projected, const torch::Tensor& summary_self,
                   const torch::Tensor& summary_other) {
  // conv([Φ; T_self; T_other]) split by the weight's columns, W_Φ·Φ + W_T·[T_self; T_other]: the
  // summaries are one vector per cloud, so they need not be broadcast over the N points.
  const int64_t D = phi.size(1);
  const auto W_T = fusion->weight.squeeze(2).narrow(1, D, 2 * D);              // D × 2D
  const auto ctx = torch::cat({summary_self, summary_other}, 1).unsqueeze(2);  // B×2D×1
  return phi + projected + torch::matmul(W_T, ctx);
}

/// The k nearest neighbours of each point of `pts`: the first k columns of a sorted larger
/// neighbourhood when one is at hand (knnIndices sorts by distance, so the k2 nearest are the first
/// k2 of the k1 nearest), else a search of their own.
torch::Tensor nearestOf(const torch::Tensor& sorted_knn, const torch::Tensor& pts, int64_t k) {
  return k <= sorted_knn.size(2) ? sorted_knn.narrow(2, 0, k) : obmnet::knnIndices(pts, pts, k);
}

}  // namespace

ObmNetOutput ObmNetImpl::forward(const torch::Tensor& src, const torch::Tensor& tgt,
                                 bool compute_loss, const torch::Tensor& tgt_surface,
                                 const torch::Tensor& tgt_normals,
                                 const torch::Tensor& match_labels) {
  OBM_ASSERT(src.dim() == 3 && src.size(1) == 3 && tgt.dim() == 3 && tgt.size(1) == 3 &&
                 src.size(0) == tgt.size(0),
             "ObmNet expects src B×3×N and tgt B×3×M");
  const int64_t kmin = std::max(config_.k1, config_.k2);
  OBM_ASSERT(src.size(2) >= kmin && tgt.size(2) >= kmin,
             "ObmNet: each cloud needs at least max(k1, k2) points");
  const int64_t B = src.size(0);
  const auto opts = src.options();

  // Eval mode re-seeds the Gumbel noise so the same pair always gives the same result.
  at::Generator eval_gen;
  if (!is_training()) eval_gen = at::make_generator<at::CPUGeneratorImpl>(config_.seed);
  at::Generator& gen = is_training() ? train_gen_ : eval_gen;

  ObmNetOutput out;
  RigidTransforms T = obmnet::identityTransforms(B, opts);
  const obmnet::NmmParams nmm_params{config_.nn_margin, config_.beta};

  // Target-side quantities do not change over the iterations: computed once.
  const auto tgt_knn1 = obmnet::knnIndices(tgt, tgt, config_.k1);
  const auto tgt_knn2 = nearestOf(tgt_knn1, tgt, config_.k2);
  // The source's neighbourhoods do not change either: the iterations move it rigidly, which
  // keeps every distance within it (the features, which see coordinates, are recomputed).
  const auto src_knn1 = obmnet::knnIndices(src, src, config_.k1);
  const auto src_knn2 = nearestOf(src_knn1, src, config_.k2);
  // Edge normals: estimated once per cloud; the source's turn with it, n = R·n₀, since the
  // estimate and its sign rule (away from the centroid) move rigidly with the cloud.
  torch::Tensor tgt_edge_normals, src_edge_normals;
  if (config_.edge_normals) {
    tgt_edge_normals =
        obmnet::orientedNormals(tgt, nearestOf(tgt_knn1, tgt, config_.normal_neighbours));
    src_edge_normals =
        obmnet::orientedNormals(src, nearestOf(src_knn1, src, config_.normal_neighbours));
  }
  const auto phi_q = extractor_->forward(tgt, tgt_knn1, tgt_edge_normals);
  // The target's per-point shares of the sampler's first layer and of the fusion (W_Φ·Φ_q) do
  // not change over the iterations either.
  torch::Tensor phi_q_logits, phi_q_fusion;
  if (sampler_) {
    phi_q_logits = sampler_->project(phi_q);
    phi_q_fusion = fusionProjection(overlap_fusion_, phi_q);
  }

  torch::Tensor loss_g = torch::zeros({}, opts), loss_n = torch::zeros({}, opts),
                loss_s = torch::zeros({}, opts), loss_c = torch::zeros({}, opts);
  const bool labelled = compute_loss && match_labels.defined();

  for (int it = 0; it < config_.n_iters; ++it) {
    // The source as moved by the iterations so far. Each iteration learns on its own input:
    // the gradient does not flow back through the earlier iterations' poses (as in RIENet).
    const auto src_cur = obmnet::transformPoints(T, src).detach();
    // Step 1: features of the moved source.
    const auto phi_p = extractor_->forward(
        src_cur, src_knn1,
        src_edge_normals.defined() ? torch::bmm(T.R, src_edge_normals).detach() : torch::Tensor());

    // Steps 2–3: overlap sampling and bias prediction.
    auto feat_p = phi_p, feat_q = phi_q;
    torch::Tensor membership = torch::ones({B, src.size(2)}, opts);
    torch::Tensor alpha = torch::ones({B}, opts);
    torch::Tensor overlap = torch::ones({B}, opts);
    if (sampler_) {
      const auto os_p = sampler_->forward(phi_p, phi_q, src_cur, gen);
      const auto os_q = sampler_->forward(phi_q, phi_p, tgt, gen, phi_q_logits);
      feat_p = fuse(overlap_fusion_, phi_p, fusionProjection(overlap_fusion_, phi_p), os_p.summary,
                    os_q.summary);
      feat_q = fuse(overlap_fusion_, phi_q, phi_q_fusion, os_q.summary, os_p.summary);
      overlap = 0.5 * (os_p.overlap + os_q.overlap);
      if (bias_) {
        alpha = bias_->forward(os_p.points, os_q.points);
        // Membership of each source point in the sampled overlap region: the probability
        // 1 − (1 − π_i)^K that K draws from π pick it at least once. The same soft value in
        // training and at inference, so the SVD weights do not change between the two modes.
        membership = os_p.membership;
      }
    }

    // Steps 4–5 → M^r (rows sum to 1). Without gradient and losses, as at inference, both run as
    // one row-wise computation (refinedMatchingMap): same quantities, no full-map temporaries.
    torch::Tensor log_match, match;  // log M^r is kept for L_s
    torch::Tensor logits;            // and its logits for L_c
    // The spatial prior (ObmNetConfig::match_spatial_sigma) is geometry: added to the final
    // logits around each source point's current place, in both forms.
    const bool spatial_prior = config_.match_spatial_sigma > 0.0;
    const bool fused_match = !compute_loss && !torch::GradMode::is_enabled();
    if (fused_match) {
      match = obmnet::refinedMatchingMap(feat_p, feat_q, src_knn2, tgt_knn2, nmm_params,
                                         config_.use_nmm, config_.match_spatial_sigma, src_cur,
                                         tgt);
    } else {
      // Step 4: matching map M_ij = ‖Φ'_pi − Φ'_qj‖₂.
      const auto M = (obmnet::pairwiseSquaredDistance(feat_p, feat_q) + 1e-12).sqrt();
      // Step 5: neighbour map matching → M^r (log kept for L_s).
      if (config_.use_nmm) {
        // S is evaluated without gradient unless `nmm_score_grad`: the NMM sums create k_s + k_t
        // full N×M tensors per iteration that back-propagation would have to keep (≈ 4 GB and half
        // of the step time for a batch of 16 × 1024 points on a CPU). M still receives the
        // neighbourhood-scaled gradient through M^e = exp(γ − S)·M.
        torch::Tensor S;
        if (config_.nmm_score_grad) {
          S = obmnet::nmmScore(M, src_knn2, tgt_knn2, nmm_params);
        } else {
          torch::NoGradGuard ng;
          S = obmnet::nmmScore(M.detach(), src_knn2, tgt_knn2, nmm_params);
        }
        logits = -(torch::exp(config_.nn_margin - S) * M);
      } else {
        logits = -M;
      }
      if (spatial_prior) {
        // log N(q_j; p_i, σ²) up to a constant per row: the map's rows become the feature match
        // times a Gaussian around where the source point now is. Without gradient: the prior
        // is geometry, fixed for this iteration like src_cur.
        const double inv_two_var =
            1.0 / (2.0 * config_.match_spatial_sigma * config_.match_spatial_sigma);
        logits = logits - obmnet::pairwiseSquaredDistance(src_cur, tgt) * inv_two_var;
      }
      log_match = torch::log_softmax(logits, 2);
      match = log_match.exp();
    }
    // Step 6: pseudo-target Q' = M^r·Q (one soft correspondence per source point).
    const auto pseudo = torch::bmm(tgt, match.transpose(1, 2));  // B×3×N
    // Step 7: inlier evaluation.
    const auto w = inlier_->forward(src_cur, pseudo, src_knn1);  // B×N in (0, 1]
    // Step 8: weighted SVD with w·α. α is the bias of the common structure: it adds weight to the
    // correspondences in the sampled overlap region (membership m_i), ω_i = w_i·(1 + α·m_i), so
    // overlapping points count (1 + α) times inside the overlap and once outside. α > 0 keeps every
    // weight positive; a single α on every weight would cancel in the normalised centroids.
    const auto omega = w * (1.0 + alpha.unsqueeze(1) * membership);
    const auto T_step = config_.planar ? obmnet::weightedProcrustesYaw(src_cur, pseudo, omega)
                                       : obmnet::weightedProcrustes(src_cur, pseudo, omega);
    T = obmnet::compose(T_step, T);

    if (compute_loss) {
      const auto src_new = obmnet::transformPoints(T_step, src_cur);
      loss_g = loss_g + (tgt_surface.defined()
                             ? obmnet::pointToPlaneAlignmentLoss(src_new, tgt_surface, tgt_normals,
                                                                 config_.loss_margin)
                             : obmnet::globalAlignmentLoss(src_new, tgt, config_.loss_margin));
      const auto kp = obmnet::selectKeypoints(w, config_.n_keypoints);
      loss_n = loss_n + obmnet::neighborhoodLoss(src_cur, tgt, pseudo, T_step, kp, config_.k1,
                                                 config_.neighbor_loss_nearest);
      loss_s = loss_s + obmnet::spatialConsistencyLoss(log_match, kp);
      // The labels index the source's own points, which every iteration keeps in order.
      if (labelled)
        loss_c = loss_c + obmnet::correspondenceLoss(logits, match_labels, config_.match_contrast);
    }
    if (it + 1 == config_.n_iters) {
      out.alpha = alpha;
      out.weights = w;
      out.overlap = overlap;
      out.membership = membership;
      const auto top = match.detach().topk(std::min<int64_t>(kMatchCandidates, match.size(2)), 2);
      out.match_prob = std::get<0>(top);
      out.match_index = std::get<1>(top);
    }
  }
  out.R = T.R;
  out.t = T.t;
  if (compute_loss) {
    out.loss_global = loss_g;
    out.loss_neighbor = loss_n;
    out.loss_spatial = loss_s;
    out.loss = loss_g + loss_n + loss_s;  // unweighted sum, as in RIENet
    if (labelled) out.loss_match = loss_c;
  }
  return out;
}

void ObmNetImpl::setSoftInferenceSampling(bool soft) {
  config_.soft_inference_sampling = soft;
  if (sampler_) sampler_->setSoftInference(soft);
}

void ObmNetImpl::setIterations(int n_iters) {
  OBM_ASSERT(n_iters >= 1, "ObmNet::setIterations: n_iters must be >= 1");
  config_.n_iters = n_iters;
}

void ObmNetImpl::setSpatialPrior(double sigma) {
  OBM_ASSERT(sigma >= 0.0, "ObmNet::setSpatialPrior: sigma must be >= 0");
  config_.match_spatial_sigma = sigma;
}

void ObmNetImpl::seedTrainingNoise(std::uint64_t seed) {
  train_gen_ = at::make_generator<at::CPUGeneratorImpl>(seed);
}

}  // namespace obm::obmnet
