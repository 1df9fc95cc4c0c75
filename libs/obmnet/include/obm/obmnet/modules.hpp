#pragma once
/// \file modules.hpp
/// Building blocks of OBMNet (docs/model.md, steps 1, 2, 3 and 7) and the kNN helpers they
/// share. Tensor layout everywhere: clouds and per-point features are B×C×N (channels first,
/// float32).
#include <torch/torch.h>

#include <cstdint>
#include <memory>

namespace obm::obmnet {

// ---------------------------------------------------------------------------------------------
// kNN helpers
// ---------------------------------------------------------------------------------------------

/// Squared Euclidean distances between the columns of `a` (B×C×N) and of `b` (B×C×M): B×N×M,
/// computed as ‖a‖² + ‖b‖² − 2aᵀb and clamped at 0 (cancellation can make it slightly negative).
torch::Tensor pairwiseSquaredDistance(const torch::Tensor& a, const torch::Tensor& b);

/// Indices (B×N×k, int64) of the k nearest columns of `ref` (B×C×M) for every column of `query`
/// (B×C×N), nearest first. When `query` and `ref` are the same cloud the point itself comes first.
torch::Tensor knnIndices(const torch::Tensor& query, const torch::Tensor& ref, int64_t k);

/// Gathers the columns of `x` (B×C×M) at `idx` (B×N×k, values in [0, M)): B×C×N×k.
torch::Tensor gatherNeighbors(const torch::Tensor& x, const torch::Tensor& idx);

/// Relative coordinates (edge vectors) x_j − x_i of every point i to its neighbours j = idx(i, ·):
/// B×C×N×k for `x` B×C×N and `idx` B×N×k.
torch::Tensor edgeVectors(const torch::Tensor& x, const torch::Tensor& idx);

/// Unit surface normals (B×3×N, no gradient, either sign) of the cloud `x` (B×3×N) from the
/// neighbourhoods `idx` (B×N×k, k >= 3): the smallest eigenvector of each neighbourhood's
/// covariance.
torch::Tensor pcaNormals(const torch::Tensor& x, const torch::Tensor& idx);

/// Unit surface normals (B×3×N, no gradient) of the cloud `x` (B×3×N) from the neighbourhoods
/// `idx` (B×N×k, k >= 3, the point itself included): the direction of least spread of each
/// neighbourhood (smallest eigenvector of its covariance), turned to point away from the cloud's
/// centroid. The sign rule moves with the cloud, so a rigid motion R, t turns the normals into
/// R·n, and two samplings of one surface get the same sign wherever the surface faces away from
/// the centre (everywhere on a convex object).
torch::Tensor orientedNormals(const torch::Tensor& x, const torch::Tensor& idx);

// ---------------------------------------------------------------------------------------------
// Step 1: densely connected EdgeConv feature extractor
// ---------------------------------------------------------------------------------------------

/// Densely connected EdgeConv (DGCNN-style, RIENet's extractor). Per edge only the relative
/// coordinate x_j − x_i over the k1-NN graph enters (with edge normals also n_i and n_j − n_i).
/// Four 1×1 Conv2d layers E→32→32→64→128 (E = 3 or 9) with BN + ReLU; each layer sees the edge
/// features and all previous layers' edge features (dense connectivity). Each layer's output is
/// max-pooled over the k neighbours; the four pooled maps are concatenated (256 channels) and a
/// Conv1d + BN + ReLU maps them to emb_dims.
/// What one EdgeConv edge (i, j) sees, d = x_j − x_i.
enum class EdgeFeatures {
  Offsets,    ///< d (3 channels)
  Normals,    ///< [n_i, n_j − n_i, d] (9 channels, the normals first; ObmNetConfig::edge_normals)
};

class DenseEdgeConvImpl : public torch::nn::Module {
 public:
  DenseEdgeConvImpl(int64_t k, int64_t emb_dims, EdgeFeatures features = EdgeFeatures::Offsets);
  /// `x`: B×3×N points → B×emb_dims×N features. `idx` (optional, B×N×k): a precomputed k-NN graph
  /// of `x`; when undefined it is computed here. `normals` (B×3×N): required with normals, and
  /// only then.
  torch::Tensor forward(const torch::Tensor& x, const torch::Tensor& idx = {},
                        const torch::Tensor& normals = {});
  int64_t k() const { return k_; }
  EdgeFeatures features() const { return features_; }
  bool withNormals() const { return features_ != EdgeFeatures::Offsets; }
  /// Channels of one edge feature: 3 or 9.
  int64_t edgeChannels() const { return edge_channels_; }
  /// The same features by the layer-by-layer path of training, also in eval mode without
  /// gradients (where forward() takes the fused inference path): the reference of its test.
  torch::Tensor forwardLayered(const torch::Tensor& x, const torch::Tensor& idx,
                               const torch::Tensor& normals = {});

 private:
  /// Eval mode without gradients: batch normalisation folded into each 1×1 convolution, every
  /// layer's output written into one edge buffer (no concatenation), neighbours laid out k-major
  /// so the max over them is a vectorised reduction. Same result as forwardLayered to float
  /// rounding; about half of an inference pass was spent in the copies this avoids.
  torch::Tensor forwardFused(const torch::Tensor& x, const torch::Tensor& idx,
                             const torch::Tensor& normals);
  int64_t k_;
  EdgeFeatures features_;
  int64_t edge_channels_;
  torch::nn::Sequential layer1_{nullptr}, layer2_{nullptr}, layer3_{nullptr}, layer4_{nullptr};
  torch::nn::Sequential out_{nullptr};
  /// Inference state of forwardFused (the module is not re-entrant, like the rest of ObmNet):
  /// the folded layers, refolded only when a weight or statistic they came from has changed
  /// (another tensor, or an in-place update such as an optimiser step or a model load), and
  /// the edge buffer ((E + 256) × k·N floats, 34 MB at E = 3, k = 32, N = 1024), kept between
  /// calls because above 32 MB glibc would map and unmap it on every call.
  struct FoldedCache;
  std::shared_ptr<FoldedCache> folded_;
  torch::Tensor edge_buffer_;
};
TORCH_MODULE(DenseEdgeConv);

// ---------------------------------------------------------------------------------------------
// Step 2: overlap sampling (OS)
// ---------------------------------------------------------------------------------------------

/// Result of the overlap sampler for one cloud (the source and the target each get one).
struct OverlapSamples {
  torch::Tensor log_pi;     ///< B×N log class probabilities log π over the cloud's points
  torch::Tensor tau;        ///< B Gumbel-softmax temperature τ
  torch::Tensor selection;  ///< B×K×N Gumbel-softmax draws S (rows sum to 1; one-hot in eval)
  torch::Tensor points;     ///< B×3×K sampled points 𝒫ᵒ = S·P
  torch::Tensor features;   ///< B×D×K sampled features Γ = Up(S·Φ)
  torch::Tensor summary;    ///< B×D overlap representation T = max over the K samples of Γ
  /// B×N soft membership m_i = 1 − (1 − π_i)^K: probability that point i is drawn at least once
  /// by K independent draws from π, i.e. that it belongs to the sampled overlap region.
  torch::Tensor membership;
  /// B overlap estimate exp(H(π))/N: the perplexity of π as a fraction of the cloud. If π is
  /// uniform over the overlapping ρN points and zero elsewhere this is exactly ρ.
  torch::Tensor overlap;
};

/// Gumbel-softmax overlap sampler (OBMNet's OS module). The features of both clouds are fused:
/// global max pooling of each, concatenation, broadcast to every point, and a shared point MLP
/// gives per-point logits (softmax over the N points = π). τ = softplus(FC(global)) + tau_min.
/// K independent draws z = softmax((log π + g)/τ), g ~ Gumbel(0,1); in eval mode the draws are
/// hard: one_hot(argmax(log π + g)).
class OverlapSamplerImpl : public torch::nn::Module {
 public:
  OverlapSamplerImpl(int64_t emb_dims, int64_t n_samples, double tau_min);
  /// `phi_self` B×D×N, `phi_other` B×D×M, `points` B×3×N; `gen` drives the Gumbel noise.
  /// Samples the cloud of `phi_self`; call twice with the roles swapped for both clouds.
  /// `projected_self`, if given, is project(phi_self) computed before: the target's features do
  /// not change over the registration iterations, so their share of the first layer need not
  /// either.
  OverlapSamples forward(const torch::Tensor& phi_self, const torch::Tensor& phi_other,
                         const torch::Tensor& points, at::Generator& gen,
                         const torch::Tensor& projected_self = {});
  /// The per-point share W_Φ·Φ of the first logits layer (B×D×N); the rest of that layer acts on
  /// the global features only.
  torch::Tensor project(const torch::Tensor& phi) const;
  /// Eval mode draws the relaxed samples of training instead of one-hot ones
  /// (ObmNetConfig::soft_inference_sampling).
  void setSoftInference(bool soft) { soft_inference_ = soft; }

 private:
  bool soft_inference_ = false;
  int64_t n_samples_;
  double tau_min_;
  torch::nn::Sequential logits_{nullptr};
  torch::nn::Sequential tau_{nullptr};
  torch::nn::Sequential up_{nullptr};
};
TORCH_MODULE(OverlapSampler);

// ---------------------------------------------------------------------------------------------
// Step 3: bias prediction (BP)
// ---------------------------------------------------------------------------------------------

/// Bias predictor: the sampled clouds stacked as a (2K)×4 matrix [𝒫ᵒ | 0 ; 𝒬ᵒ | 1] go through a
/// shared point MLP (4→64→128→256, ReLU), max pooling, FC 256→128→1 and softplus: α > 0 per pair.
class BiasPredictorImpl : public torch::nn::Module {
 public:
  BiasPredictorImpl();
  /// `src_samples` B×3×K, `tgt_samples` B×3×K' → α, shape B, strictly positive.
  torch::Tensor forward(const torch::Tensor& src_samples, const torch::Tensor& tgt_samples);

 private:
  torch::nn::Sequential point_mlp_{nullptr};
  torch::nn::Sequential head_{nullptr};
};
TORCH_MODULE(BiasPredictor);

// ---------------------------------------------------------------------------------------------
// Step 7: inlier evaluation
// ---------------------------------------------------------------------------------------------

/// RIENet's inlier evaluation: the k1-neighbourhood edge vectors of p_i and of its pseudo
/// correspondence q'_i (same neighbour indices, from the source graph) go through a shared block
/// (Conv2d 3→dim→2·dim, BN, LeakyReLU 0.2); the difference feeds a feature head and an attention
/// head (softmax over k); the attention-weighted sum over k goes through Conv1d 2·dim→16→8→1 and
/// w_i = 1 − tanh(|·|) ∈ (0, 1].
class InlierEvaluatorImpl : public torch::nn::Module {
 public:
  explicit InlierEvaluatorImpl(int64_t dim);
  /// `src` B×3×N, `pseudo_tgt` B×3×N, `idx` B×N×k (source k-NN) → weights B×N in (0, 1].
  torch::Tensor forward(const torch::Tensor& src, const torch::Tensor& pseudo_tgt,
                        const torch::Tensor& idx);

 private:
  /// Eval mode without gradient on a CPU: batch normalisation folded into the convolutions and
  /// kept until a weight or statistic changes (as DenseEdgeConv's), both clouds' edges in one
  /// block.
  torch::Tensor forwardFused(const torch::Tensor& src, const torch::Tensor& pseudo_tgt,
                             const torch::Tensor& idx);
  struct FoldedCache;
  std::shared_ptr<FoldedCache> folded_;
  torch::nn::Sequential shared_{nullptr};
  torch::nn::Sequential feature_head_{nullptr};
  torch::nn::Conv2d attention_head_{nullptr};
  torch::nn::Sequential score_{nullptr};
};
TORCH_MODULE(InlierEvaluator);

}  // namespace obm::obmnet
