#pragma once
/// \file kernels.hpp
/// Raw CPU kernels of OBMNet's inference (no autograd, float32): the k-nearest-neighbour search
/// and the whole matching step (steps 4–5 of docs/model.md) in two passes over the rows of the
/// matching map. They compute the same quantities as the tensor expressions of the training graph
/// (modules.cpp, nmm.cpp), to float rounding, without their full-map temporaries.
#include <torch/torch.h>

namespace obm::obmnet::detail {

/// The k nearest points of `ref` (B×3×M) to each point of `query` (B×3×N), as B×N×k int64
/// indices sorted by increasing distance (ties: the lower index first). CPU tensors; computed
/// in float32.
torch::Tensor knnSortedCpu(const torch::Tensor& query, const torch::Tensor& ref, int64_t k);

/// out[i, ·] = Σ_a X[idx(i, a), ·] for a float CPU table X (R×C) and indices idx (N×k): each
/// output row written once from its k rows. With `with_squares` the sums of X² follow in the same
/// row (N × 2C). NMM's neighbourhood sums when no gradient is needed (nmm.cpp).
torch::Tensor neighbourRowSumsCpu(const torch::Tensor& X, const torch::Tensor& idx,
                                  bool with_squares);

/// What the matching step refines M with.
struct MatchKernelParams {
  bool use_nmm = true;  ///< neighbour map matching (step 5); else M^r = row-softmax(−M)
  double gamma = 0.7;   ///< γ of M^e = exp(γ − S)·M
  double beta = 1e-6;   ///< β of D_ij
  /// The spatial prior's 1/(2σ²) (ObmNetConfig::match_spatial_sigma; 0 = off): the final cost
  /// gets + ‖p_i − q_j‖²/(2σ²) before its row-softmax, with p_i, q_j the points given to
  /// matchingMapCpu.
  double prior_inv_two_var = 0.0;
};

/// The refined matching map M^r (B×N×M, rows sum to 1) from the fused features: M_ij =
/// ‖f_pi − f_qj‖ (step 4), then, with NMM, M′ = row-softmax(−M), S from the k_s × k_t
/// neighbourhood sums of M′ and M′², M^r = row-softmax(−exp(γ − S)·M) (step 5; nmm.hpp has the
/// formulas). `feat_p` B×D×N, `feat_q` B×D×M, `src_idx` B×N×k_s, `tgt_idx` B×M×k_t. CPU float32,
/// no gradient. With params.prior_inv_two_var > 0, `src_points` B×3×N and `tgt_points` B×3×M
/// are the points of the spatial prior (otherwise unused).
torch::Tensor matchingMapCpu(const torch::Tensor& feat_p, const torch::Tensor& feat_q,
                             const torch::Tensor& src_idx, const torch::Tensor& tgt_idx,
                             const MatchKernelParams& params,
                             const torch::Tensor& src_points = {},
                             const torch::Tensor& tgt_points = {});

}  // namespace obm::obmnet::detail
