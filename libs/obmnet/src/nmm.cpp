#include "obm/obmnet/nmm.hpp"

#include "obm/core/errors.hpp"

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

/// Step 5, second and third bullets, from the neighbourhood sums A (Σ M′) and d (Σ M′²):
/// S_ij = D_ij·A_ij / K. d_ij is clamped from below (1e-20) so 1/d_ij stays finite where the
/// softmax underflows: such columns then dominate D's normalisation exactly as an infinitesimal d
/// would.
torch::Tensor scoreFromSums(const torch::Tensor& A, const torch::Tensor& d, int64_t pairs,
                            const NmmParams& p) {
  // D only normalises the score across the row; its gradient through 1/d is unbounded where the
  // softmax underflows (d → 0), so D is treated as a constant weight (no gradient) and the
  // learning signal flows through A.
  const auto inv = 1.0 / d.detach().clamp_min(1e-20) + p.beta;
  const auto D = inv / inv.sum(2, /*keepdim=*/true);
  // S_ij = (D_ij / K) Σ_{p∈N(p_i)} Σ_{q∈N(q_j)} M′: K = k_s·k_t neighbour pairs (a mean).
  return D * A / static_cast<double>(pairs);
}

}  // namespace

torch::Tensor nmmScore(const torch::Tensor& M, const torch::Tensor& src_idx,
                       const torch::Tensor& tgt_idx, const NmmParams& params) {
  checkShapes(M, src_idx, tgt_idx);
  const int64_t B = M.size(0), N = M.size(1), Mt = M.size(2);
  const int64_t ks = src_idx.size(2), kt = tgt_idx.size(2);
  const auto Mp = torch::softmax(-M, 2);  // M′ = row-softmax(−M)
  const auto Mp2 = Mp * Mp;
  // Row sums over the source neighbours: R_A[i,j] = Σ_a M′[src_idx(i,a), j] (same for M′²).
  auto rowA = torch::zeros_like(Mp);
  auto rowD = torch::zeros_like(Mp);
  for (int64_t a = 0; a < ks; ++a) {
    const auto index = src_idx.select(2, a).unsqueeze(2).expand({B, N, Mt});
    rowA = rowA + Mp.gather(1, index);
    rowD = rowD + Mp2.gather(1, index);
  }
  // Column sums over the target neighbours: A[i,j] = Σ_b R_A[i, tgt_idx(j,b)].
  auto A = torch::zeros_like(Mp);
  auto d = torch::zeros_like(Mp);
  for (int64_t b = 0; b < kt; ++b) {
    const auto index = tgt_idx.select(2, b).unsqueeze(1).expand({B, N, Mt});
    A = A + rowA.gather(2, index);
    d = d + rowD.gather(2, index);
  }
  return scoreFromSums(A, d, ks * kt, params);
}

torch::Tensor nmmEnhancedCost(const torch::Tensor& M, const torch::Tensor& src_idx,
                              const torch::Tensor& tgt_idx, const NmmParams& params) {
  return torch::exp(params.gamma - nmmScore(M, src_idx, tgt_idx, params)) * M;
}

torch::Tensor nmm(const torch::Tensor& M, const torch::Tensor& src_idx,
                  const torch::Tensor& tgt_idx, const NmmParams& params) {
  return torch::softmax(-nmmEnhancedCost(M, src_idx, tgt_idx, params), 2);
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
