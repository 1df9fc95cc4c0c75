#pragma once
/// \file nmm.hpp
/// Neighbour map matching (NMM, docs/model.md, step 5): refines the matching map M with the
/// agreement of the matching probabilities between the k2-neighbourhoods of a source point and of
/// a target point.
#include <torch/torch.h>

namespace obm::obmnet {

/// Parameters of NMM.
struct NmmParams {
  double gamma = 0.7;  ///< γ (RIENet's nn_margin): M^e = exp(γ − S)·M
  double beta = 1e-6;  ///< β in D_ij = (1/d_ij + β) / Σ_j (1/d_ij + β)
};

/// The enhanced cost M^e = exp(γ − S) ⊙ M of step 5, computed in O(N·M·k):
///   M′ = row-softmax(−M);
///   A_ij = Σ_{a∈N(p_i)} Σ_{b∈N(q_j)} M′_ab,  d_ij = Σ_{a∈N(p_i)} Σ_{b∈N(q_j)} (M′_ab)²;
///   D_ij = (1/d_ij + β) / Σ_j' (1/d_ij' + β);  S_ij = D_ij · A_ij / (k_s·k_t).
/// Both double sums are taken as a row sum over the source neighbours (gather of k_s rows of M′)
/// followed by a column sum over the target neighbours (gather of k_t columns): O(N·M·(k_s+k_t))
/// instead of the literal [N,k,M,k] gather.
/// `M` B×N×M feature distances, `src_idx` B×N×k_s (k2-NN of each source point in the source),
/// `tgt_idx` B×M×k_t (k2-NN of each target point in the target). Returns M^e, B×N×M.
torch::Tensor nmmEnhancedCost(const torch::Tensor& M, const torch::Tensor& src_idx,
                              const torch::Tensor& tgt_idx, const NmmParams& params);

/// The neighbourhood score S of step 5 alone (B×N×M), so that a caller can evaluate it without
/// gradient: M^e = exp(γ − S) ⊙ M.
torch::Tensor nmmScore(const torch::Tensor& M, const torch::Tensor& src_idx,
                       const torch::Tensor& tgt_idx, const NmmParams& params);

/// The refined matching map M^r = row-softmax(−M^e), B×N×M (rows sum to 1).
torch::Tensor nmm(const torch::Tensor& M, const torch::Tensor& src_idx,
                  const torch::Tensor& tgt_idx, const NmmParams& params);

/// Steps 4–5 together: the refined matching map M^r (B×N×M, rows sum to 1) from the fused
/// features `feat_p` B×D×N and `feat_q` B×D×M, M_ij = ‖f_pi − f_qj‖; with `use_nmm` M^r = nmm(M),
/// else row-softmax(−M). Without gradient, on float CPU tensors, it runs as raw row kernels (two
/// passes over the rows, no full-map temporaries); otherwise as the tensor graph above.
/// With `spatial_sigma` σ > 0 the final logits get the spatial prior −‖p_i − q_j‖²/(2σ²) for the
/// points `src_points` B×3×N and `tgt_points` B×3×M (ObmNetConfig::match_spatial_sigma).
torch::Tensor refinedMatchingMap(const torch::Tensor& feat_p, const torch::Tensor& feat_q,
                                 const torch::Tensor& src_idx, const torch::Tensor& tgt_idx,
                                 const NmmParams& params, bool use_nmm = true,
                                 double spatial_sigma = 0.0,
                                 const torch::Tensor& src_points = {},
                                 const torch::Tensor& tgt_points = {});

/// Reference implementation of `nmmEnhancedCost` with the literal B×N×k×M×k gather of M′
/// (memory and time O(N·M·k²)). For tests on small inputs only.
torch::Tensor nmmEnhancedCostLiteral(const torch::Tensor& M, const torch::Tensor& src_idx,
                                     const torch::Tensor& tgt_idx, const NmmParams& params);

}  // namespace obm::obmnet
