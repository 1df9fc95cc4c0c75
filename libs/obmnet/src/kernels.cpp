#include "kernels.hpp"

#include <ATen/Parallel.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <limits>
#include <vector>

#include "obm/core/errors.hpp"

// The row loops below are written so that the compiler vectorises them (no branches in the
// element loops, reductions over explicit lanes). On x86-64 they are compiled twice, for the
// baseline and for AVX2 + FMA, and the loader picks the one the CPU runs (GCC function clones).
#if defined(__GNUC__) && !defined(__clang__) && defined(__x86_64__)
#define OBM_VECTOR_CLONES __attribute__((target_clones("arch=x86-64-v3", "default")))
#else
#define OBM_VECTOR_CLONES
#endif

namespace obm::obmnet::detail {

namespace rows {

constexpr int kLanes = 16;

/// e^x in float, to about two units in the last place, as branch-free arithmetic that
/// vectorises: x = n·ln2 + r with |r| ≤ ln2/2, e^r by its degree-7 Taylor-like (minimax)
/// polynomial, 2^n from the exponent bits. Below −87.3 the result is 0 (torch gives subnormals
/// there, which no sum here can tell apart); above 88 it saturates at e^88.
inline float expf(float x) {
  constexpr float kLo = -87.33654f, kHi = 88.0f;
  const bool under = x < kLo;
  x = std::min(std::max(x, kLo), kHi);
  const float n = std::floor(x * 1.44269504088896341f + 0.5f);
  float r = x - n * 0.693359375f;  // ln 2 split in two parts, so n·ln2 is exact enough
  r = r + n * 2.12194440e-4f;
  float p = 1.9875691500e-4f;
  p = p * r + 1.3981999507e-3f;
  p = p * r + 8.3334519073e-3f;
  p = p * r + 4.1665795894e-2f;
  p = p * r + 1.6666665459e-1f;
  p = p * r + 5.0000001201e-1f;
  p = p * r * r + r + 1.0f;
  const std::int32_t bits = (static_cast<std::int32_t>(n) + 127) << 23;
  float scale;
  std::memcpy(&scale, &bits, sizeof scale);
  return under ? 0.0f : p * scale;
}

inline float sum(const float* x, int64_t n) {
  float acc[kLanes] = {};
  int64_t j = 0;
  for (; j + kLanes <= n; j += kLanes)
    for (int l = 0; l < kLanes; ++l) acc[l] += x[j + l];
  float s = 0.0f;
  for (int l = 0; l < kLanes; ++l) s += acc[l];
  for (; j < n; ++j) s += x[j];
  return s;
}

inline float min(const float* x, int64_t n) {
  float acc[kLanes];
  for (int l = 0; l < kLanes; ++l) acc[l] = x[0];
  int64_t j = 0;
  for (; j + kLanes <= n; j += kLanes)
    for (int l = 0; l < kLanes; ++l) acc[l] = std::min(acc[l], x[j + l]);
  float m = acc[0];
  for (int l = 1; l < kLanes; ++l) m = std::min(m, acc[l]);
  for (; j < n; ++j) m = std::min(m, x[j]);
  return m;
}

/// dst = row-softmax(−src) over n entries (dst may be src): exp(−(x − min)) / Σ.
OBM_VECTOR_CLONES void softmaxOfNegative(const float* src, float* dst, int64_t n) {
  const float lo = min(src, n);
  for (int64_t j = 0; j < n; ++j) dst[j] = rows::expf(lo - src[j]);
  const float inv = 1.0f / sum(dst, n);
  for (int64_t j = 0; j < n; ++j) dst[j] *= inv;
}

/// Squared distances from (qx, qy, qz) to the n points of the coordinate rows x, y, z.
OBM_VECTOR_CLONES void squaredDistances(float qx, float qy, float qz, const float* x,
                                        const float* y, const float* z, float* d, int64_t n) {
  for (int64_t j = 0; j < n; ++j) {
    const float dx = x[j] - qx, dy = y[j] - qy, dz = z[j] - qz;
    d[j] = dx * dx + dy * dy + dz * dz;
  }
}

/// Inserts (d, j) into the ascending list (b, s) of length k, dropping its last entry, into
/// (nb, ns): entry i keeps b_i if b_i ≤ d (ties: the earlier first), else takes d at the first
/// such place and b_{i−1} after it. No data-dependent branch.
OBM_VECTOR_CLONES void insertSorted(const float* b, const std::int32_t* s, float* nb,
                                    std::int32_t* ns, int64_t k, float d, std::int32_t j) {
  nb[0] = b[0] <= d ? b[0] : d;
  ns[0] = b[0] <= d ? s[0] : j;
  for (int64_t i = 1; i < k; ++i) {
    const bool keep = b[i] <= d, shift = b[i - 1] > d;
    nb[i] = keep ? b[i] : (shift ? b[i - 1] : d);
    ns[i] = keep ? s[i] : (shift ? s[i - 1] : j);
  }
}

/// Row i of the feature distance map in place: ab_ij = f_pi·f_qj becomes
/// √(max(‖f_pi‖² + ‖f_qj‖² − 2·ab_ij, 0) + 10⁻¹²), as pairwiseSquaredDistance + sqrt in the graph.
OBM_VECTOR_CLONES void featureDistances(float* ab, float aa, const float* bb, int64_t n) {
  for (int64_t j = 0; j < n; ++j)
    ab[j] = std::sqrt(std::max(aa + bb[j] - 2.0f * ab[j], 0.0f) + 1e-12f);
}

/// The source-neighbourhood sums of one row: RA = Σ_a M′[a, ·], RD = Σ_a M′[a, ·]² over the k_s
/// rows `nbr` of M′ (m columns each).
OBM_VECTOR_CLONES void neighbourhoodSums(const float* Mp, const int64_t* nbr, int64_t ks, int64_t m,
                                         float* RA, float* RD) {
  const float* first = Mp + nbr[0] * m;
  for (int64_t j = 0; j < m; ++j) {
    RA[j] = first[j];
    RD[j] = first[j] * first[j];
  }
  for (int64_t a = 1; a < ks; ++a) {
    const float* row = Mp + nbr[a] * m;
    for (int64_t j = 0; j < m; ++j) {
      RA[j] += row[j];
      RD[j] += row[j] * row[j];
    }
  }
}

/// RA = Σ_a X[a, ·] over the k rows `nbr` of X (m columns each): neighbourhoodSums without the
/// squares.
OBM_VECTOR_CLONES void neighbourhoodSum(const float* X, const int64_t* nbr, int64_t k, int64_t m,
                                        float* RA) {
  const float* first = X + nbr[0] * m;
  for (int64_t j = 0; j < m; ++j) RA[j] = first[j];
  for (int64_t a = 1; a < k; ++a) {
    const float* row = X + nbr[a] * m;
    for (int64_t j = 0; j < m; ++j) RA[j] += row[j];
  }
}

/// Rows of a block are processed together so that the gathers over the target neighbours move
/// whole vectors: the block's sums are kept transposed, entry (j, r) at j·kBlock + r.
constexpr int64_t kBlock = 16;

/// Column r of the transposed block buffers from the row sums RA, RD (m entries each).
OBM_VECTOR_CLONES void scatterColumn(const float* RA, const float* RD, int64_t r, int64_t m,
                                     float* RAt, float* RDt) {
  for (int64_t j = 0; j < m; ++j) {
    RAt[j * kBlock + r] = RA[j];
    RDt[j * kBlock + r] = RD[j];
  }
}

/// For every target point j and every row r of the block: A = Σ_b RA[tgt(j, b)], d likewise, and
/// the unnormalised weight inv = 1/max(d, 10⁻²⁰) + β of D (nmm.cpp, scoreFromSums); A is written
/// over `At`, inv over `invt`. Also accumulates Σ_j inv per row into `inv_sum`.
OBM_VECTOR_CLONES void targetSums(const float* RAt, const float* RDt, const int64_t* tgt,
                                  int64_t kt, int64_t m, float beta, float* At, float* invt,
                                  float* inv_sum) {
  for (int64_t r = 0; r < kBlock; ++r) inv_sum[r] = 0.0f;
  for (int64_t j = 0; j < m; ++j) {
    const int64_t* t = tgt + j * kt;
    float a[kBlock], d[kBlock];
    for (int64_t r = 0; r < kBlock; ++r) a[r] = d[r] = 0.0f;
    for (int64_t b = 0; b < kt; ++b) {
      const float* ra = RAt + t[b] * kBlock;
      const float* rd = RDt + t[b] * kBlock;
      for (int64_t r = 0; r < kBlock; ++r) {
        a[r] += ra[r];
        d[r] += rd[r];
      }
    }
    for (int64_t r = 0; r < kBlock; ++r) {
      const float inv = 1.0f / std::max(d[r], 1e-20f) + beta;
      At[j * kBlock + r] = a[r];
      invt[j * kBlock + r] = inv;
      inv_sum[r] += inv;
    }
  }
}

/// Row r of the block: M^e_j = exp(γ − S_j)·M_j with S_j = inv_j·A_j·scale, scale =
/// 1/(Σ_j inv_j · k_s·k_t), written over `cost` (which may be M).
OBM_VECTOR_CLONES void enhancedCost(const float* M, const float* At, const float* invt, int64_t r,
                                    float gamma, float scale, int64_t m, float* cost) {
  for (int64_t j = 0; j < m; ++j)
    cost[j] = rows::expf(gamma - invt[j * kBlock + r] * At[j * kBlock + r] * scale) * M[j];
}

/// The spatial prior on one row of the cost: cost_j += k·‖q_j − p‖² for the target coordinate
/// rows x, y, z (n entries) and the source point p = (px, py, pz).
OBM_VECTOR_CLONES void addSpatialPrior(float* cost, float px, float py, float pz, const float* x,
                                       const float* y, const float* z, float k, int64_t n) {
  for (int64_t j = 0; j < n; ++j) {
    const float dx = x[j] - px, dy = y[j] - py, dz = z[j] - pz;
    cost[j] += k * (dx * dx + dy * dy + dz * dz);
  }
}

}  // namespace rows

torch::Tensor knnSortedCpu(const torch::Tensor& query, const torch::Tensor& ref, int64_t k) {
  OBM_ASSERT(query.dim() == 3 && ref.dim() == 3 && query.size(1) == 3 && ref.size(1) == 3 &&
                 query.size(0) == ref.size(0) && query.is_cpu() && ref.is_cpu(),
             "knnSortedCpu expects CPU points B×3×N and B×3×M");
  const int64_t B = query.size(0), N = query.size(2), M = ref.size(2);
  OBM_ASSERT(k >= 1 && k <= M, "knnSortedCpu: k must be in [1, number of reference points]");
  const auto q = query.to(torch::kFloat32).contiguous();
  const auto r = ref.to(torch::kFloat32).contiguous();
  auto out = torch::empty({B, N, k}, torch::TensorOptions().dtype(torch::kLong));
  const float* qp = q.data_ptr<float>();
  const float* rp = r.data_ptr<float>();
  int64_t* op = out.data_ptr<int64_t>();
  at::parallel_for(0, B * N, 32, [&](int64_t begin, int64_t end) {
    std::vector<float> dist(static_cast<std::size_t>(M));
    std::vector<float> best(static_cast<std::size_t>(k)), next_best(best.size());
    std::vector<std::int32_t> slot(best.size()), next_slot(best.size());
    for (int64_t row = begin; row < end; ++row) {
      const int64_t b = row / N, i = row % N;
      const float* qb = qp + b * 3 * N;
      const float* x = rp + b * 3 * M;
      rows::squaredDistances(qb[i], qb[N + i], qb[2 * N + i], x, x + M, x + 2 * M, dist.data(), M);
      // The k smallest kept sorted; most candidates fail the one comparison with the k-th, the
      // others are inserted by one branch-free pass over the list.
      std::fill(best.begin(), best.end(), std::numeric_limits<float>::max());
      std::fill(slot.begin(), slot.end(), 0);
      for (int64_t j = 0; j < M; ++j) {
        const float dj = dist[static_cast<std::size_t>(j)];
        if (!(dj < best[static_cast<std::size_t>(k - 1)])) continue;
        rows::insertSorted(best.data(), slot.data(), next_best.data(), next_slot.data(), k, dj,
                           static_cast<std::int32_t>(j));
        best.swap(next_best);
        slot.swap(next_slot);
      }
      int64_t* idx = op + row * k;
      for (int64_t s = 0; s < k; ++s) idx[s] = slot[static_cast<std::size_t>(s)];
    }
  });
  return out;
}

torch::Tensor neighbourRowSumsCpu(const torch::Tensor& X, const torch::Tensor& idx,
                                  bool with_squares) {
  OBM_ASSERT(X.dim() == 2 && idx.dim() == 2 && X.is_cpu() && X.scalar_type() == torch::kFloat32,
             "neighbourRowSumsCpu expects a float CPU table R×C and indices N×k");
  const auto Xc = X.contiguous();
  const auto I = idx.to(torch::kLong).contiguous();
  const int64_t rows = I.size(0), k = I.size(1), C = Xc.size(1);
  OBM_ASSERT(k >= 1 && I.min().item<int64_t>() >= 0 && I.max().item<int64_t>() < Xc.size(0),
             "neighbourRowSumsCpu: indices must be rows of the table");
  const int64_t width = with_squares ? 2 * C : C;
  auto out = torch::empty({rows, width}, Xc.options());
  const float* x = Xc.data_ptr<float>();
  const int64_t* id = I.data_ptr<int64_t>();
  float* o = out.data_ptr<float>();
  at::parallel_for(0, rows, 16, [&](int64_t begin, int64_t end) {
    for (int64_t i = begin; i < end; ++i) {
      float* dst = o + i * width;
      if (with_squares)
        rows::neighbourhoodSums(x, id + i * k, k, C, dst, dst + C);
      else
        rows::neighbourhoodSum(x, id + i * k, k, C, dst);
    }
  });
  return out;
}

torch::Tensor matchingMapCpu(const torch::Tensor& feat_p, const torch::Tensor& feat_q,
                             const torch::Tensor& src_idx, const torch::Tensor& tgt_idx,
                             const MatchKernelParams& params, const torch::Tensor& src_points,
                             const torch::Tensor& tgt_points) {
  OBM_ASSERT(feat_p.dim() == 3 && feat_q.dim() == 3 && feat_p.size(0) == feat_q.size(0) &&
                 feat_p.size(1) == feat_q.size(1) && feat_p.is_cpu() && feat_q.is_cpu() &&
                 feat_p.scalar_type() == torch::kFloat32 && feat_q.scalar_type() == torch::kFloat32,
             "matchingMapCpu expects float CPU features B×D×N and B×D×M");
  const int64_t B = feat_p.size(0), N = feat_p.size(2), M = feat_q.size(2);
  // The spatial prior's points as float coordinate rows (B×3×N, B×3×M).
  const bool prior = params.prior_inv_two_var > 0.0;
  torch::Tensor pp, pq;
  if (prior) {
    OBM_ASSERT(src_points.defined() && tgt_points.defined() && src_points.dim() == 3 &&
                   tgt_points.dim() == 3 && src_points.size(0) == B && src_points.size(1) == 3 &&
                   src_points.size(2) == N && tgt_points.size(0) == B &&
                   tgt_points.size(1) == 3 && tgt_points.size(2) == M,
               "matchingMapCpu: the spatial prior needs points B×3×N and B×3×M");
    pp = src_points.to(torch::kFloat32).contiguous();
    pq = tgt_points.to(torch::kFloat32).contiguous();
  }
  const float* ppp = prior ? pp.data_ptr<float>() : nullptr;
  const float* pqp = prior ? pq.data_ptr<float>() : nullptr;
  const float prior_k = static_cast<float>(params.prior_inv_two_var);
  // Row i of batch b of the final cost gets the prior (before the final row-softmax).
  auto addPrior = [&](float* cost, int64_t b, int64_t i) {
    const float* p = ppp + b * 3 * N;
    const float* q = pqp + b * 3 * M;
    rows::addSpatialPrior(cost, p[i], p[N + i], p[2 * N + i], q, q + M, q + 2 * M, prior_k, M);
  };
  // Step 4: the Gram matrix by GEMM; every other operation is done row by row below.
  auto map = torch::bmm(feat_p.transpose(1, 2), feat_q).contiguous();  // B×N×M
  const auto aa = feat_p.pow(2).sum(1).contiguous();                   // B×N
  const auto bb = feat_q.pow(2).sum(1).contiguous();                   // B×M
  float* mp = map.data_ptr<float>();
  const float* ap = aa.data_ptr<float>();
  const float* bp = bb.data_ptr<float>();
  torch::Tensor soft;  // M′ = row-softmax(−M), read across rows by the second pass
  if (params.use_nmm) soft = torch::empty_like(map);
  float* sp = params.use_nmm ? soft.data_ptr<float>() : nullptr;
  at::parallel_for(0, B * N, 16, [&](int64_t begin, int64_t end) {
    for (int64_t row = begin; row < end; ++row) {
      float* m = mp + row * M;
      rows::featureDistances(m, ap[row], bp + (row / N) * M, M);
      // Without NMM the refined map is the row-softmax of −M itself (with the prior), in place;
      // with NMM, M′ is of the features alone.
      if (prior && !params.use_nmm) addPrior(m, row / N, row % N);
      rows::softmaxOfNegative(m, params.use_nmm ? sp + row * M : m, M);
    }
  });
  if (!params.use_nmm) return map;

  OBM_ASSERT(src_idx.dim() == 3 && tgt_idx.dim() == 3 && src_idx.size(0) == B &&
                 src_idx.size(1) == N && tgt_idx.size(0) == B && tgt_idx.size(1) == M,
             "matchingMapCpu: src_idx must be B×N×k_s and tgt_idx B×M×k_t");
  const auto si = src_idx.to(torch::kLong).contiguous();
  const auto ti = tgt_idx.to(torch::kLong).contiguous();
  const int64_t ks = si.size(2), kt = ti.size(2);
  // The row loops read M′ at these indices unchecked: one range check here, O((N + M)·k).
  OBM_ASSERT(ks >= 1 && kt >= 1 && si.min().item<int64_t>() >= 0 && si.max().item<int64_t>() < N &&
                 ti.min().item<int64_t>() >= 0 && ti.max().item<int64_t>() < M,
             "matchingMapCpu: neighbour indices must be in [0, N) for the source and [0, M) for "
             "the target");
  const int64_t* sip = si.data_ptr<int64_t>();
  const int64_t* tip = ti.data_ptr<int64_t>();
  const float gamma = static_cast<float>(params.gamma);
  const float beta = static_cast<float>(params.beta);
  // Second pass, over blocks of rows: row i reads the k_s rows of M′ of its neighbours and only
  // its own row of M, which it overwrites with M^r.
  const int64_t blocks_per_batch = (N + rows::kBlock - 1) / rows::kBlock;
  at::parallel_for(0, B * blocks_per_batch, 1, [&](int64_t begin, int64_t end) {
    std::vector<float> buffer(static_cast<std::size_t>((2 + 4 * rows::kBlock) * M));
    float* RA = buffer.data();
    float* RD = RA + M;
    float* RAt = RD + M;
    float* RDt = RAt + rows::kBlock * M;
    float* At = RDt + rows::kBlock * M;
    float* invt = At + rows::kBlock * M;
    float inv_sum[rows::kBlock];
    for (int64_t blk = begin; blk < end; ++blk) {
      const int64_t b = blk / blocks_per_batch;
      const int64_t i0 = (blk % blocks_per_batch) * rows::kBlock;
      const int64_t n_rows = std::min(rows::kBlock, N - i0);
      for (int64_t r = 0; r < rows::kBlock; ++r) {
        // Rows past the end of a short last block repeat its first row (computed, not written).
        const int64_t i = i0 + (r < n_rows ? r : 0);
        rows::neighbourhoodSums(sp + b * N * M, sip + (b * N + i) * ks, ks, M, RA, RD);
        rows::scatterColumn(RA, RD, r, M, RAt, RDt);
      }
      rows::targetSums(RAt, RDt, tip + b * M * kt, kt, M, beta, At, invt, inv_sum);
      for (int64_t r = 0; r < n_rows; ++r) {
        // S_ij = D_ij·A_ij/(k_s·k_t), D_ij = inv_j / Σ_j inv_j.
        const float scale = 1.0f / (inv_sum[r] * static_cast<float>(ks * kt));
        float* m = mp + (b * N + i0 + r) * M;
        rows::enhancedCost(m, At, invt, r, gamma, scale, M, m);
        if (prior) addPrior(m, b, i0 + r);
        rows::softmaxOfNegative(m, m, M);
      }
    }
  });
  return map;
}

}  // namespace obm::obmnet::detail
