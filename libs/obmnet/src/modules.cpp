#include "obm/obmnet/modules.hpp"

#include <cmath>
#include <vector>

#include "kernels.hpp"
#include "obm/core/errors.hpp"

namespace obm::obmnet {

namespace nn = torch::nn;

torch::Tensor pairwiseSquaredDistance(const torch::Tensor& a, const torch::Tensor& b) {
  OBM_ASSERT(a.dim() == 3 && b.dim() == 3 && a.size(0) == b.size(0) && a.size(1) == b.size(1),
             "pairwiseSquaredDistance expects B×C×N and B×C×M");
  const auto aa = a.pow(2).sum(1);                   // B×N
  const auto bb = b.pow(2).sum(1);                   // B×M
  const auto ab = torch::bmm(a.transpose(1, 2), b);  // B×N×M
  return (aa.unsqueeze(2) + bb.unsqueeze(1) - 2.0 * ab).clamp_min(0.0);
}

torch::Tensor knnIndices(const torch::Tensor& query, const torch::Tensor& ref, int64_t k) {
  OBM_ASSERT(k >= 1 && k <= ref.size(2),
             "knnIndices: k must be in [1, number of reference points]");
  torch::NoGradGuard no_grad;  // indices only
  if (query.is_cpu() && ref.is_cpu() && query.scalar_type() == torch::kFloat32 &&
      ref.scalar_type() == torch::kFloat32)
    return detail::knnSortedCpu(query, ref, k);  // a sorted k-list per row, no N×M map or top-k
  const auto d = pairwiseSquaredDistance(query, ref);
  return std::get<1>(d.topk(k, /*dim=*/2, /*largest=*/false, /*sorted=*/true));
}

torch::Tensor gatherNeighbors(const torch::Tensor& x, const torch::Tensor& idx) {
  OBM_ASSERT(x.dim() == 3 && idx.dim() == 3 && x.size(0) == idx.size(0),
             "gatherNeighbors expects x B×C×M and idx B×N×k");
  const int64_t B = x.size(0), C = x.size(1), M = x.size(2);
  const int64_t N = idx.size(1), k = idx.size(2);
  // Offsets turn per-batch indices into rows of the flattened (B·M)×C table.
  const auto offsets = torch::arange(B, idx.options()).view({B, 1, 1}) * M;
  const auto flat = (idx + offsets).reshape({-1});
  const auto table = x.transpose(1, 2).reshape({B * M, C});
  return table.index_select(0, flat).view({B, N, k, C}).permute({0, 3, 1, 2});
}

torch::Tensor edgeVectors(const torch::Tensor& x, const torch::Tensor& idx) {
  return gatherNeighbors(x, idx) - x.unsqueeze(3);
}

torch::Tensor pcaNormals(const torch::Tensor& x, const torch::Tensor& idx) {
  OBM_ASSERT(x.dim() == 3 && x.size(1) == 3 && idx.dim() == 3 && idx.size(0) == x.size(0) &&
                 idx.size(1) == x.size(2) && idx.size(2) >= 3,
             "pcaNormals expects points B×3×N and neighbours B×N×k with k >= 3");
  torch::NoGradGuard no_grad;
  const auto nb = gatherNeighbors(x.detach(), idx);                        // B×3×N×k
  const auto a = (nb - nb.mean(3, true)).permute({0, 2, 1, 3});           // B×N×3×k
  const auto C = torch::matmul(a, a.transpose(2, 3)).to(torch::kFloat64);  // B×N×3×3
  // Eigenvalues ascending: the first eigenvector spans the direction of least spread.
  const auto n = std::get<1>(torch::linalg_eigh(C)).select(3, 0);  // B×N×3
  return n.to(x.scalar_type()).permute({0, 2, 1}).contiguous();    // B×3×N
}

torch::Tensor orientedNormals(const torch::Tensor& x, const torch::Tensor& idx) {
  const auto n = pcaNormals(x, idx);
  torch::NoGradGuard no_grad;
  // Away from the centroid; a point exactly at it keeps the solver's sign.
  const auto outward = x.detach() - x.detach().mean(2, true);
  const auto sign = torch::where((n * outward).sum(1, true) < 0, -1.0, 1.0).to(n.scalar_type());
  return (n * sign).contiguous();
}

// ---------------------------------------------------------------------------------------------

namespace {

/// Slope of every LeakyReLU of the network (DGCNN's and RIENet's 0.2).
constexpr double kLeakySlope = 0.2;

nn::Sequential conv2dBnRelu(int64_t in, int64_t out) {
  // The bias is left out because batch normalisation removes any per-channel constant.
  return nn::Sequential(nn::Conv2d(nn::Conv2dOptions(in, out, 1).bias(false)), nn::BatchNorm2d(out),
                        nn::ReLU());
}

nn::Sequential conv2dBnLrelu(int64_t in, int64_t out) {
  return nn::Sequential(nn::Conv2d(nn::Conv2dOptions(in, out, 1).bias(false)), nn::BatchNorm2d(out),
                        nn::LeakyReLU(nn::LeakyReLUOptions().negative_slope(kLeakySlope)));
}

/// Appends Conv1d(1×1, no bias) + BN + LeakyReLU(0.2) to `seq` (Sequentials cannot be nested).
void addConv1dBnLrelu(nn::Sequential& seq, int64_t in, int64_t out) {
  seq->push_back(nn::Conv1d(nn::Conv1dOptions(in, out, 1).bias(false)));
  seq->push_back(nn::BatchNorm1d(out));
  seq->push_back(nn::LeakyReLU(nn::LeakyReLUOptions().negative_slope(kLeakySlope)));
}

/// Appends Conv2d(1×1, no bias) + BN + LeakyReLU(0.2) to `seq`.
void addConv2dBnLrelu(nn::Sequential& seq, int64_t in, int64_t out) {
  seq->push_back(nn::Conv2d(nn::Conv2dOptions(in, out, 1).bias(false)));
  seq->push_back(nn::BatchNorm2d(out));
  seq->push_back(nn::LeakyReLU(nn::LeakyReLUOptions().negative_slope(kLeakySlope)));
}

}  // namespace

DenseEdgeConvImpl::DenseEdgeConvImpl(int64_t k, int64_t emb_dims, EdgeFeatures features)
    : k_(k),
      features_(features),
      edge_channels_(features == EdgeFeatures::Normals ? 9 : 3) {
  // Dense connectivity: layer l sees the edge features (E = 3 or 9) and the outputs of layers
  // 1..l−1.
  const int64_t E = edge_channels_;
  layer1_ = register_module("layer1", conv2dBnRelu(E, 32));
  layer2_ = register_module("layer2", conv2dBnRelu(E + 32, 32));
  layer3_ = register_module("layer3", conv2dBnRelu(E + 32 + 32, 64));
  layer4_ = register_module("layer4", conv2dBnRelu(E + 32 + 32 + 64, 128));
  out_ = register_module(
      "out",
      nn::Sequential(nn::Conv1d(nn::Conv1dOptions(32 + 32 + 64 + 128, emb_dims, 1).bias(false)),
                     nn::BatchNorm1d(emb_dims), nn::ReLU()));
}

torch::Tensor DenseEdgeConvImpl::forward(const torch::Tensor& x, const torch::Tensor& idx_in,
                                         const torch::Tensor& normals) {
  OBM_ASSERT(x.dim() == 3 && x.size(1) == 3, "DenseEdgeConv expects points B×3×N");
  OBM_ASSERT(normals.defined() == withNormals() &&
                 (!normals.defined() || normals.sizes() == x.sizes()),
             "DenseEdgeConv: normals B×3×N are required with edge normals, and only then");
  const auto idx = idx_in.defined() ? idx_in : knnIndices(x, x, k_);
  OBM_ASSERT(
      idx.dim() == 3 && idx.size(0) == x.size(0) && idx.size(1) == x.size(2) && idx.size(2) == k_,
      "DenseEdgeConv: neighbour graph has the wrong shape");
  if (!is_training() && !torch::GradMode::is_enabled() && x.device().is_cpu())
    return forwardFused(x, idx, normals);
  return forwardLayered(x, idx, normals);
}

torch::Tensor DenseEdgeConvImpl::forwardLayered(const torch::Tensor& x, const torch::Tensor& idx,
                                                const torch::Tensor& normals) {
  // B×E×N×k: relative coordinates (translation invariant), after [n_i, n_j − n_i] with normals.
  auto e = edgeVectors(x, idx);
  if (withNormals()) {
    const auto dn = edgeVectors(normals, idx);
    e = torch::cat({normals.unsqueeze(3).expand_as(dn), dn, e}, 1);
  }
  const auto h1 = layer1_->forward(e);
  const auto h2 = layer2_->forward(torch::cat({e, h1}, 1));
  const auto h3 = layer3_->forward(torch::cat({e, h1, h2}, 1));
  const auto h4 = layer4_->forward(torch::cat({e, h1, h2, h3}, 1));
  // Max over the k neighbours after each layer, then concatenation (32+32+64+128 = 256).
  const auto pooled = torch::cat({h1.amax(3), h2.amax(3), h3.amax(3), h4.amax(3)}, 1);
  return out_->forward(pooled);
}

namespace {

/// A bias-free 1×1 convolution followed by batch normalisation in eval mode, as one affine map:
/// BN(W·x) = s ⊙ (W·x − μ) + β with s = γ / √(σ² + ε), so W′ = diag(s)·W and b′ = β − s ⊙ μ.
struct FoldedLayer {
  torch::Tensor W;  ///< out × in
  torch::Tensor b;  ///< out × 1
};

template <class ConvImpl, class BnImpl>
FoldedLayer foldConvBn(const nn::Sequential& seq, std::size_t at = 0) {
  const auto* conv = seq->ptr(at)->as<ConvImpl>();
  const auto* bn = seq->ptr(at + 1)->as<BnImpl>();
  OBM_ASSERT(conv && bn && !conv->bias.defined() && bn->options.affine() &&
                 bn->options.track_running_stats(),
             "DenseEdgeConv: expected a bias-free convolution followed by batch normalisation");
  const auto s = bn->weight / (bn->running_var + bn->options.eps()).sqrt();
  FoldedLayer f;
  f.W = conv->weight.reshape({conv->weight.size(0), conv->weight.size(1)}) * s.unsqueeze(1);
  f.b = (bn->bias - bn->running_mean * s).unsqueeze(1);
  return f;
}

/// Identity and in-place version of every tensor of the given blocks: equal keys, equal weights.
using FoldKey = std::vector<std::pair<const void*, std::uint32_t>>;
FoldKey foldKey(std::initializer_list<const nn::Sequential*> blocks) {
  FoldKey key;
  for (const auto* block : blocks) {
    for (const auto& t : (*block)->parameters())
      key.emplace_back(t.unsafeGetTensorImpl(), t._version());
    for (const auto& t : (*block)->buffers())
      key.emplace_back(t.unsafeGetTensorImpl(), t._version());
  }
  return key;
}

}  // namespace

struct DenseEdgeConvImpl::FoldedCache {
  FoldKey key;
  FoldedLayer layers[4];
  FoldedLayer out;
};

torch::Tensor DenseEdgeConvImpl::forwardFused(const torch::Tensor& x, const torch::Tensor& idx,
                                              const torch::Tensor& normals) {
  const int64_t B = x.size(0), N = x.size(2), k = k_, L = k * N;
  auto key = foldKey({&layer1_, &layer2_, &layer3_, &layer4_, &out_});
  if (!folded_ || folded_->key != key) {
    auto f = std::make_shared<FoldedCache>();
    f->key = std::move(key);
    f->layers[0] = foldConvBn<nn::Conv2dImpl, nn::BatchNorm2dImpl>(layer1_);
    f->layers[1] = foldConvBn<nn::Conv2dImpl, nn::BatchNorm2dImpl>(layer2_);
    f->layers[2] = foldConvBn<nn::Conv2dImpl, nn::BatchNorm2dImpl>(layer3_);
    f->layers[3] = foldConvBn<nn::Conv2dImpl, nn::BatchNorm2dImpl>(layer4_);
    f->out = foldConvBn<nn::Conv1dImpl, nn::BatchNorm1dImpl>(out_);
    folded_ = std::move(f);
  }
  const auto& layers = folded_->layers;
  const auto& out = folded_->out;
  const int64_t E = edge_channels_;
  int64_t channels = E;
  for (const auto& l : layers) channels += l.W.size(0);
  const int64_t pooled_channels = channels - E;
  // Rows: e (E), h1, h2, h3, h4; columns: edge (j, i) at j·N + i (neighbour rank j of point i).
  // Layer l reads rows [0, c_l) — exactly the concatenation [e, h1, …, h_{l−1}] of the layered
  // path — and writes its output into the next rows.
  if (!edge_buffer_.defined() || edge_buffer_.numel() < channels * L ||
      edge_buffer_.dtype() != x.dtype())
    edge_buffer_ = torch::empty({channels * L}, x.options());
  auto buffer = edge_buffer_.narrow(0, 0, channels * L).view({channels, L});
  std::vector<torch::Tensor> features;
  features.reserve(static_cast<std::size_t>(B));
  for (int64_t b = 0; b < B; ++b) {
    const auto xb = x[b].contiguous();                       // 3×N
    const auto nbr = idx[b].t().contiguous().reshape({-1});  // k·N, neighbour-rank major
    auto e = buffer.narrow(0, E - 3, 3);
    torch::index_select_out(e, xb, 1, nbr);   // x_j
    e.view({3, k, N}).sub_(xb.unsqueeze(1));  // x_j − x_i
    if (features_ == EdgeFeatures::Normals) {
      const auto nbn = normals[b].contiguous();                                 // 3×N
      buffer.narrow(0, 0, 3).view({3, k, N}).copy_(nbn.unsqueeze(1).expand({3, k, N}));  // n_i
      auto dn = buffer.narrow(0, 3, 3);
      torch::index_select_out(dn, nbn, 1, nbr);   // n_j
      dn.view({3, k, N}).sub_(nbn.unsqueeze(1));  // n_j − n_i
    }
    int64_t c = E;
    for (const auto& l : layers) {
      const int64_t c_out = l.W.size(0);
      auto h = buffer.narrow(0, c, c_out);
      torch::addmm_out(h, l.b, l.W, buffer.narrow(0, 0, c));
      h.relu_();
      c += c_out;
    }
    const auto pooled = buffer.narrow(0, E, pooled_channels).view({pooled_channels, k, N}).amax(1);
    features.push_back(torch::addmm(out.b, out.W, pooled).relu_());
  }
  return torch::stack(features, 0);
}

// ---------------------------------------------------------------------------------------------

OverlapSamplerImpl::OverlapSamplerImpl(int64_t emb_dims, int64_t n_samples, double tau_min)
    : n_samples_(n_samples), tau_min_(tau_min) {
  const int64_t D = emb_dims;
  const int64_t hidden = std::max<int64_t>(D / 4, 16);
  // Per-point input: own feature (D) + both global features (2D). The last layer has no bias:
  // π is a softmax over the points, which a common offset does not change.
  nn::Sequential logits;
  addConv1dBnLrelu(logits, 3 * D, D);
  addConv1dBnLrelu(logits, D, hidden);
  logits->push_back(nn::Conv1d(nn::Conv1dOptions(hidden, 1, 1).bias(false)));
  logits_ = register_module("logits", logits);
  tau_ = register_module(
      "tau", nn::Sequential(nn::Linear(2 * D, hidden), nn::ReLU(), nn::Linear(hidden, 1)));
  // Up(·): back to the feature width after the sampling (a learnt 1×1 map on the K samples).
  up_ = register_module(
      "up", nn::Sequential(nn::Conv1d(nn::Conv1dOptions(D, D, 1)),
                           nn::LeakyReLU(nn::LeakyReLUOptions().negative_slope(kLeakySlope))));
}

namespace {

/// The first logits layer of the sampler, checked to be the Conv1d over [Φ_i; global] (3D rows).
const nn::Conv1dImpl& firstLogitsLayer(const nn::Sequential& logits, int64_t D) {
  const auto* first = logits->begin()->ptr()->as<nn::Conv1dImpl>();
  OBM_ASSERT(first && first->weight.size(1) == 3 * D,
             "OverlapSampler: the first logits layer must be a Conv1d over 3D channels");
  return *first;
}

}  // namespace

torch::Tensor OverlapSamplerImpl::project(const torch::Tensor& phi) const {
  const int64_t D = phi.size(1);
  const auto W = firstLogitsLayer(logits_, D).weight.squeeze(2);  // D_out × 3D
  return torch::matmul(W.narrow(1, 0, D), phi);
}

OverlapSamples OverlapSamplerImpl::forward(const torch::Tensor& phi_self,
                                           const torch::Tensor& phi_other,
                                           const torch::Tensor& points, at::Generator& gen,
                                           const torch::Tensor& projected_self) {
  const int64_t B = phi_self.size(0), D = phi_self.size(1), N = phi_self.size(2);
  OBM_ASSERT(points.size(2) == N && phi_other.size(1) == D, "OverlapSampler: inconsistent shapes");
  OverlapSamples out;
  // Fusion of the two clouds: global max pooling of each, concatenated (own first) and broadcast.
  const auto global = torch::cat({phi_self.amax(2), phi_other.amax(2)}, 1);  // B×2D
  // The first 1×1 convolution sees [Φ_i; global] per point. Split by columns, W·[Φ_i; g] =
  // W_Φ·Φ_i + W_g·g: the global part is one vector per cloud instead of a broadcast 2D×N block
  // (two thirds of the layer's multiplications and the concatenation's copy saved).
  const auto& first = firstLogitsLayer(logits_, D);
  const auto W = first.weight.squeeze(2);  // D_out × 3D
  auto z = (projected_self.defined() ? projected_self : project(phi_self)) +
           torch::matmul(W.narrow(1, D, 2 * D), global.unsqueeze(2));
  if (first.bias.defined()) z = z + first.bias.view({1, -1, 1});
  auto layer = logits_->begin();
  for (++layer; layer != logits_->end(); ++layer) z = layer->forward(z);
  out.log_pi = torch::log_softmax(z.squeeze(1), 1);                        // B×N
  out.tau = torch::softplus(tau_->forward(global)).squeeze(1) + tau_min_;  // B

  // Gumbel(0,1) noise g = −log(−log u), drawn on the CPU from the given generator so a fixed
  // seed reproduces the same draws, then moved to the module's device.
  const float eps = 1e-10f;
  auto u = torch::rand({B, n_samples_, N}, gen, torch::TensorOptions().dtype(torch::kFloat32));
  u = u.clamp(eps, 1.0f - eps).to(phi_self.device(), phi_self.scalar_type());
  const auto gumbel = -torch::log(-torch::log(u));
  const auto scores = out.log_pi.unsqueeze(1) + gumbel;  // B×K×N
  if (is_training() || soft_inference_) {
    // Differentiable relaxation: softmax((log π + g)/τ).
    out.selection = torch::softmax(scores / out.tau.view({B, 1, 1}), 2);
    const auto S_t = out.selection.transpose(1, 2);  // B×N×K
    out.points = torch::bmm(points, S_t);            // B×3×K
    out.features = up_->forward(torch::bmm(phi_self, S_t));
  } else {
    // Inference, by default: the exact categorical draw one_hot(argmax(log π + g)) (τ does not
    // change it). S·P and S·Φ are then the drawn columns themselves: gathered, not multiplied.
    const auto drawn = scores.argmax(2);  // B×K
    out.selection = torch::one_hot(drawn, N).to(phi_self.scalar_type());
    const auto cols = drawn.unsqueeze(1);
    out.points = points.gather(2, cols.expand({B, points.size(1), n_samples_}));
    out.features = up_->forward(phi_self.gather(2, cols.expand({B, D, n_samples_})));
  }
  out.summary = out.features.amax(2);  // B×D

  const auto pi = out.log_pi.exp();
  // m_i = 1 − (1 − π_i)^K, computed as 1 − exp(K·log1p(−π_i)) for accuracy with small π_i.
  out.membership =
      1.0 - torch::exp(static_cast<double>(n_samples_) * torch::log1p(-pi.clamp_max(1.0 - 1e-6)));
  // Perplexity of π over N: exp(H(π))/N ∈ (0, 1].
  const auto entropy = -(pi * out.log_pi).sum(1);
  out.overlap = torch::exp(entropy) / static_cast<double>(N);
  return out;
}

// ---------------------------------------------------------------------------------------------

BiasPredictorImpl::BiasPredictorImpl() {
  point_mlp_ = register_module(
      "point_mlp", nn::Sequential(nn::Conv1d(nn::Conv1dOptions(4, 64, 1)), nn::ReLU(),
                                  nn::Conv1d(nn::Conv1dOptions(64, 128, 1)), nn::ReLU(),
                                  nn::Conv1d(nn::Conv1dOptions(128, 256, 1)), nn::ReLU()));
  head_ =
      register_module("head", nn::Sequential(nn::Linear(256, 128), nn::ReLU(), nn::Linear(128, 1)));
}

torch::Tensor BiasPredictorImpl::forward(const torch::Tensor& src_samples,
                                         const torch::Tensor& tgt_samples) {
  OBM_ASSERT(src_samples.dim() == 3 && src_samples.size(1) == 3 && tgt_samples.dim() == 3 &&
                 tgt_samples.size(1) == 3,
             "BiasPredictor expects sampled points B×3×K");
  const int64_t B = src_samples.size(0);
  // The (2K)×4 matrix [𝒫ᵒ | 0 ; 𝒬ᵒ | 1], channels first: B×4×(K+K').
  const auto src_tag = torch::zeros({B, 1, src_samples.size(2)}, src_samples.options());
  const auto tgt_tag = torch::ones({B, 1, tgt_samples.size(2)}, tgt_samples.options());
  const auto x =
      torch::cat({torch::cat({src_samples, src_tag}, 1), torch::cat({tgt_samples, tgt_tag}, 1)}, 2);
  const auto pooled = point_mlp_->forward(x).amax(2);  // B×256
  // softplus keeps α > 0; the tiny floor keeps it strictly positive where softplus underflows.
  return torch::softplus(head_->forward(pooled)).squeeze(1) + 1e-6;
}

// ---------------------------------------------------------------------------------------------

InlierEvaluatorImpl::InlierEvaluatorImpl(int64_t dim) {
  nn::Sequential shared;
  addConv2dBnLrelu(shared, 3, dim);
  addConv2dBnLrelu(shared, dim, 2 * dim);
  shared_ = register_module("shared", shared);
  feature_head_ = register_module("feature_head", conv2dBnLrelu(2 * dim, 2 * dim));
  // No bias: the attention is a softmax over k, which a constant offset does not change.
  attention_head_ =
      register_module("attention_head", nn::Conv2d(nn::Conv2dOptions(2 * dim, 1, 1).bias(false)));
  nn::Sequential score;
  addConv1dBnLrelu(score, 2 * dim, 16);
  addConv1dBnLrelu(score, 16, 8);
  score->push_back(nn::Conv1d(nn::Conv1dOptions(8, 1, 1)));
  score_ = register_module("score", score);
}

torch::Tensor InlierEvaluatorImpl::forward(const torch::Tensor& src,
                                           const torch::Tensor& pseudo_tgt,
                                           const torch::Tensor& idx) {
  OBM_ASSERT(src.sizes() == pseudo_tgt.sizes(),
             "InlierEvaluator: src and pseudo-target differ in shape");
  if (!is_training() && !torch::GradMode::is_enabled() && src.is_cpu() &&
      src.scalar_type() == torch::kFloat32)
    return forwardFused(src, pseudo_tgt, idx);
  const int64_t B = src.size(0);
  const auto e_p = edgeVectors(src, idx);         // B×3×N×k
  const auto e_q = edgeVectors(pseudo_tgt, idx);  // same neighbour indices: the correspondences
  // One pass through the shared block for both, so they share the batch statistics too.
  const auto h = shared_->forward(torch::cat({e_p, e_q}, 0));
  const auto diff = h.narrow(0, 0, B) - h.narrow(0, B, B);  // B×2dim×N×k
  const auto feat = feature_head_->forward(diff);
  const auto att = torch::softmax(attention_head_->forward(diff), 3);  // B×1×N×k
  const auto agg = (feat * att).sum(3);                                // B×2dim×N
  const auto s = score_->forward(agg).squeeze(1);                      // B×N
  // RIENet's w = 1 − tanh(|s|). In float it is exactly 0 once |s| > ~9; a row where every weight
  // is 0 is solved with uniform weights by weightedProcrustes. (The algebraically equal
  // 2·sigmoid(−2|s|) keeps such weights tiny but positive, so the SVD then follows the few least
  // saturated points: on clean pairs the untrained network's error went from 28° to 84°.)
  return 1.0 - torch::tanh(s.abs());
}

struct InlierEvaluatorImpl::FoldedCache {
  FoldKey key;
  FoldedLayer first, second, feature;  // shared block (two layers), feature head
};

torch::Tensor InlierEvaluatorImpl::forwardFused(const torch::Tensor& src,
                                                const torch::Tensor& pseudo_tgt,
                                                const torch::Tensor& idx) {
  // Eval mode, no gradient: batch normalisation folded into the 1×1 convolutions (as in
  // DenseEdgeConv::forwardFused), the edges of both clouds side by side in one rank-major
  // C × 2kN block per batch element, activations in place.
  auto key = foldKey({&shared_, &feature_head_});
  if (!folded_ || folded_->key != key) {
    auto f = std::make_shared<FoldedCache>();
    f->key = std::move(key);
    f->first = foldConvBn<nn::Conv2dImpl, nn::BatchNorm2dImpl>(shared_, 0);
    f->second = foldConvBn<nn::Conv2dImpl, nn::BatchNorm2dImpl>(shared_, 3);
    f->feature = foldConvBn<nn::Conv2dImpl, nn::BatchNorm2dImpl>(feature_head_, 0);
    folded_ = std::move(f);
  }
  const auto& F = *folded_;
  const int64_t B = src.size(0), N = src.size(2), k = idx.size(2), L = k * N;
  const auto W_att = attention_head_->weight.view({1, -1});  // 1 × 2dim
  std::vector<torch::Tensor> aggregated;
  aggregated.reserve(static_cast<std::size_t>(B));
  for (int64_t b = 0; b < B; ++b) {
    const auto nbr = idx[b].t().contiguous().reshape({-1});  // k·N, neighbour-rank major
    auto e = torch::empty({3, 2 * L}, src.options());
    for (int c = 0; c < 2; ++c) {
      const auto x = (c == 0 ? src[b] : pseudo_tgt[b]).contiguous();  // 3×N
      auto part = e.narrow(1, c * L, L);
      torch::index_select_out(part, x, 1, nbr);
      part.view({3, k, N}).sub_(x.unsqueeze(1));  // edge vectors x_j − x_i
    }
    auto h = torch::addmm(F.first.b, F.first.W, e);
    torch::leaky_relu_(h, kLeakySlope);
    h = torch::addmm(F.second.b, F.second.W, h);
    torch::leaky_relu_(h, kLeakySlope);
    const auto diff = h.narrow(1, 0, L) - h.narrow(1, L, L);  // 2dim × kN
    auto feat = torch::addmm(F.feature.b, F.feature.W, diff);
    torch::leaky_relu_(feat, kLeakySlope);
    const auto att = torch::softmax(torch::mm(W_att, diff).view({k, N}), 0);  // over the k
    aggregated.push_back((feat.view({-1, k, N}) * att.unsqueeze(0)).sum(1));  // 2dim × N
  }
  const auto s = score_->forward(torch::stack(aggregated, 0)).squeeze(1);  // B×N
  return 1.0 - torch::tanh(s.abs());
}

}  // namespace obm::obmnet
