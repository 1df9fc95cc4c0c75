#include "obm/obmnet/nmm.hpp"

#include <vector>

#include "kernels.hpp"
#include "obm/core/errors.hpp"
#include "obm/obmnet/modules.hpp"

namespace obm::obmnet {

namespace {

void checkShapes(const torch::Tensor& M, const torch::Tensor& src_idx,
                 const torch::Tensor& tgt_idx) {
  OBM_ASSERT(M.dim() == 3 && src_idx.dim() == 3 && tgt_idx.dim() == 3, "NMM expects 3-D tensors");
  OBM_ASSERT(src_idx.size(0) == M.size(0) && src_idx.size(1) == M.size(1),
             "NMM: src_idx must be B×N×k for a B×N×M matching map");
  OBM_ASSERT(tgt_idx.size(0) == M.size(0) && tgt_idx.size(1) == M.size(2),
             "NMM: tgt_idx must be B×M×k for a B×N×M matching map");
}

/// Σ_a X[idx(i, a), ·] with autograd (index_select of whole rows, accumulated).
torch::Tensor neighbourRowSum(const torch::Tensor& X, const torch::Tensor& idx) {
  auto sum = X.index_select(0, idx.select(1, 0));
  for (int64_t a = 1; a < idx.size(1); ++a) sum = sum + X.index_select(0, idx.select(1, a));
  return sum;
}

/// Step 5, second and third bullets, from the neighbourhood sums A (Σ M′) and d (Σ M′²):
/// S_ij = D_ij·A_ij / K. d_ij is clamped from below (1e-20) so 1/d_ij stays finite where the
/// softmax underflows: such columns then dominate D's normalisation exactly as an infinitesimal d
/// would. `target_dim`: the dimension of j (2 for B×N×M sums, 1 for transposed B×M×N ones).
torch::Tensor scoreFromSums(const torch::Tensor& A, const torch::Tensor& d, int64_t pairs,
                            const NmmParams& p, int64_t target_dim = 2) {
  // D only normalises the score across the row; its gradient through 1/d is unbounded where the
  // softmax underflows (d → 0), so D is treated as a constant weight (no gradient) and the
  // learning signal flows through A.
  const auto inv = 1.0 / d.detach().clamp_min(1e-20) + p.beta;
  const auto D = inv / inv.sum(target_dim, /*keepdim=*/true);  // normalised over j
  // S_ij = (D_ij / K) Σ_{p∈N(p_i)} Σ_{q∈N(q_j)} M′: K = k_s·k_t neighbour pairs (a mean).
  return D * A / static_cast<double>(pairs);
}

}  // namespace

torch::Tensor nmmScore(const torch::Tensor& M, const torch::Tensor& src_idx,
                       const torch::Tensor& tgt_idx, const NmmParams& params) {
  checkShapes(M, src_idx, tgt_idx);
  const int64_t B = M.size(0);
  const int64_t ks = src_idx.size(2), kt = tgt_idx.size(2);
  const auto Mp = torch::softmax(-M, 2);  // M′ = row-softmax(−M)
  const bool fast =
      !torch::GradMode::is_enabled() && Mp.scalar_type() == torch::kFloat32 && Mp.device().is_cpu();
  const auto Mp2 = fast ? torch::Tensor() : Mp * Mp;
  // The double sums as a row sum over the source neighbours followed by a column sum over the
  // target neighbours, per batch element: O(N·M·(k_s + k_t)) instead of the literal gather with
  // indices expanded over the whole map (nmmEnhancedCostLiteral).
  const int64_t Mt = M.size(2);
  std::vector<torch::Tensor> As, ds;
  for (int64_t b = 0; b < B; ++b) {
    // R_A[i,·] = Σ_a M′[src_idx(i,a), ·] and R_D of M′² beside it (N × 2M), transposed so that
    // A[i,j] = Σ_b R_A[i, tgt_idx(j,b)] is again a sum of whole rows: Aᵀ[j,·] = Σ_b
    // R_Aᵀ[tgt_idx(j,b), ·].
    const auto R = fast ? detail::neighbourRowSumsCpu(Mp[b], src_idx[b], /*with_squares=*/true)
                        : neighbourRowSum(torch::cat({Mp[b], Mp2[b]}, 1), src_idx[b]);
    const auto Rt = R.t().contiguous();  // 2M × N: rows of R_Aᵀ, then of R_Dᵀ
    const auto sum = [fast](const torch::Tensor& X, const torch::Tensor& idx) {
      return fast ? detail::neighbourRowSumsCpu(X, idx, /*with_squares=*/false)
                  : neighbourRowSum(X, idx);
    };
    As.push_back(sum(Rt.narrow(0, 0, Mt), tgt_idx[b]));   // Aᵀ, M × N
    ds.push_back(sum(Rt.narrow(0, Mt, Mt), tgt_idx[b]));  // dᵀ
  }
  const auto At = B == 1 ? As[0].unsqueeze(0) : torch::stack(As, 0);  // B × M × N
  const auto dt = B == 1 ? ds[0].unsqueeze(0) : torch::stack(ds, 0);
  // S from the transposed sums, normalised over j (dimension 1 here), returned as B × N × M.
  return scoreFromSums(At, dt, ks * kt, params, /*target_dim=*/1).transpose(1, 2);
}

torch::Tensor nmmEnhancedCost(const torch::Tensor& M, const torch::Tensor& src_idx,
                              const torch::Tensor& tgt_idx, const NmmParams& params) {
  return torch::exp(params.gamma - nmmScore(M, src_idx, tgt_idx, params)) * M;
}

torch::Tensor nmm(const torch::Tensor& M, const torch::Tensor& src_idx,
                  const torch::Tensor& tgt_idx, const NmmParams& params) {
  return torch::softmax(-nmmEnhancedCost(M, src_idx, tgt_idx, params), 2);
}

torch::Tensor refinedMatchingMap(const torch::Tensor& feat_p, const torch::Tensor& feat_q,
                                 const torch::Tensor& src_idx, const torch::Tensor& tgt_idx,
                                 const NmmParams& params, bool use_nmm, double spatial_sigma,
                                 const torch::Tensor& src_points,
                                 const torch::Tensor& tgt_points) {
  const double inv_two_var = spatial_sigma > 0.0 ? 1.0 / (2.0 * spatial_sigma * spatial_sigma)
                                                 : 0.0;
  if (!torch::GradMode::is_enabled() && feat_p.is_cpu() && feat_q.is_cpu() &&
      feat_p.scalar_type() == torch::kFloat32 && feat_q.scalar_type() == torch::kFloat32)
    return detail::matchingMapCpu(
        feat_p, feat_q, src_idx, tgt_idx,
        detail::MatchKernelParams{use_nmm, params.gamma, params.beta, inv_two_var}, src_points,
        tgt_points);
  const auto M = (pairwiseSquaredDistance(feat_p, feat_q) + 1e-12).sqrt();
  auto cost = use_nmm ? nmmEnhancedCost(M, src_idx, tgt_idx, params) : M;
  if (inv_two_var > 0.0)
    cost = cost + pairwiseSquaredDistance(src_points, tgt_points) * inv_two_var;
  return torch::softmax(-cost, 2);
}

torch::Tensor nmmEnhancedCostLiteral(const torch::Tensor& M, const torch::Tensor& src_idx,
                                     const torch::Tensor& tgt_idx, const NmmParams& params) {
  checkShapes(M, src_idx, tgt_idx);
  const int64_t B = M.size(0), N = M.size(1), Mt = M.size(2);
  const int64_t ks = src_idx.size(2), kt = tgt_idx.size(2);
  const auto Mp = torch::softmax(-M, 2);
  // G1[b,i,a,j] = M′[b, src_idx(b,i,a), j]: B×N×ks×M.
  const auto rows = src_idx.reshape({B, N * ks, 1}).expand({B, N * ks, Mt});
  const auto G1 = Mp.gather(1, rows);  // B×(N·ks)×M
  // G2[b,i,a,j,c] = G1[b,i,a, tgt_idx(b,j,c)]: B×N×ks×M×kt.
  const auto cols = tgt_idx.reshape({B, 1, Mt * kt}).expand({B, N * ks, Mt * kt});
  const auto G2 = G1.gather(2, cols).view({B, N, ks, Mt, kt});
  const auto A = G2.sum({2, 4});
  const auto d = G2.pow(2).sum({2, 4});
  const auto inv = 1.0 / d.clamp_min(1e-20) + params.beta;
  const auto D = inv / inv.sum(2, true);
  const auto S = D * G2.mean({2, 4});
  return torch::exp(params.gamma - S) * M;
}

}  // namespace obm::obmnet
