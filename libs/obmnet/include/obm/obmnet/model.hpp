#pragma once
/// \file model.hpp
/// OBMNet: unsupervised, overlap-aware partial-to-partial registration (AAAI 2024) on top of
/// RIENet's iterative scheme. One forward pass runs `n_iters` iterations of: features → overlap
/// sampling → bias prediction → matching map → neighbour map matching → pseudo-target → inlier
/// evaluation → weighted SVD, and (optionally) the unsupervised losses L_g + L_n + L_s. See
/// docs/model.md.
#include <torch/torch.h>

#include "obm/obmnet/config.hpp"
#include "obm/obmnet/modules.hpp"

namespace obm::obmnet {

/// Outputs of one forward pass. (R, t) is T_target_source: q ≈ R·p + t.
/// Match candidates per source point kept in ObmNetOutput (fewer when the target is smaller).
inline constexpr int64_t kMatchCandidates = 4;

struct ObmNetOutput {
  torch::Tensor R;        ///< B×3×3 rotation, composed over the iterations
  torch::Tensor t;        ///< B×3 translation
  torch::Tensor alpha;    ///< B bias coefficient α > 0 of the last iteration (ones without BP)
  torch::Tensor weights;  ///< B×N inlier weights w ∈ (0, 1] of the last iteration
  /// B overlap estimate in [0, 1] of the last iteration: mean over source and target of the
  /// perplexity of π divided by the number of points (ones without OS).
  torch::Tensor overlap;
  /// B×N membership m_i = 1 − (1 − π_i)^K of each source point in the sampled overlap region
  /// (last iteration; ones without BP): where α applies in the weighted SVD.
  torch::Tensor membership;
  /// B×N×C indices of each source point's C = kMatchCandidates most probable target points in the
  /// last iteration's matching map M^r (int64, most probable first), and B×N×C those
  /// probabilities: the network's putative correspondences, for a robust estimator beside the
  /// weighted SVD (ObmNetRegistrar::Options::ransac_iterations).
  torch::Tensor match_index, match_prob;
  /// Scalars (summed over iterations, mean over the batch); defined only when compute_loss.
  torch::Tensor loss, loss_global, loss_neighbor, loss_spatial;
  /// Correspondence term L_c summed over iterations (correspondenceLoss); defined only when
  /// compute_loss and `match_labels` are given. Not part of `loss`.
  torch::Tensor loss_match;
};

/// The OBMNet module. Train mode: soft Gumbel-softmax sampling and batch statistics; eval mode:
/// hard (one-hot) sampling with noise re-seeded from `config.seed` at every call (repeatable).
/// Inference should run under torch::NoGradGuard.
class ObmNetImpl : public torch::nn::Module {
 public:
  /// Validates `config` (ConfigError on bad values) and builds the sub-modules the flags ask for.
  explicit ObmNetImpl(const ObmNetConfig& config);

  /// `src` B×3×N, `tgt` B×3×M (float32, same device as the module; N and M may differ, both
  /// >= max(k1, k2)). Returns T_target_source and the diagnostics; the losses only when
  /// `compute_loss`. Throws ContractError on malformed shapes.
  /// With `tgt_surface` / `tgt_normals` (B×3×S, optional, training only) L_g is computed in its
  /// point-to-plane form against them (pointToPlaneAlignmentLoss) instead of against `tgt`.
  /// With `match_labels` (B×N int64, −1 = none; training only, teacher.hpp) the output also
  /// carries L_c of every iteration's matching map against them.
  ObmNetOutput forward(const torch::Tensor& src, const torch::Tensor& tgt,
                       bool compute_loss = false, const torch::Tensor& tgt_surface = {},
                       const torch::Tensor& tgt_normals = {},
                       const torch::Tensor& match_labels = {});

  const ObmNetConfig& config() const { return config_; }

  /// Overrides ObmNetConfig::soft_inference_sampling of the loaded weights (an inference choice;
  /// the weights do not change).
  void setSoftInferenceSampling(bool soft);

  /// Overrides ObmNetConfig::n_iters for inference: the iterations share their weights, so a
  /// pass may run more of them than training did (a larger start offset is closed in more steps).
  void setIterations(int n_iters);

  /// Overrides ObmNetConfig::match_spatial_sigma (0 = no prior). An inference choice: the
  /// weights do not change, though a model trained with the prior has features tuned to it.
  void setSpatialPrior(double sigma);

  /// Restarts the train-mode Gumbel noise stream from `seed`. The trainer seeds it per step from
  /// (seed, epoch, step, rank), so a run resumed from a checkpoint draws the noise the
  /// uninterrupted run drew, and ends on the same weights bit for bit.
  void seedTrainingNoise(std::uint64_t seed);

 private:
  ObmNetConfig config_;
  obmnet::DenseEdgeConv extractor_{nullptr};
  obmnet::OverlapSampler sampler_{nullptr};    ///< null without OS
  torch::nn::Conv1d overlap_fusion_{nullptr};  ///< null without OS
  obmnet::BiasPredictor bias_{nullptr};        ///< null without BP
  obmnet::InlierEvaluator inlier_{nullptr};
  at::Generator train_gen_;  ///< Gumbel noise stream of train mode
};
TORCH_MODULE(ObmNet);

}  // namespace obm::obmnet
