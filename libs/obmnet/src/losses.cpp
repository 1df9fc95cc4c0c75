#include "obm/obmnet/losses.hpp"

#include <algorithm>
#include <cmath>

#include "obm/core/errors.hpp"
#include "obm/obmnet/modules.hpp"

namespace obm::obmnet {

torch::Tensor huber(const torch::Tensor& x, double c) {
  return torch::where(x < c, 0.5 * x * x, c * x - 0.5 * c * c);
}

torch::Tensor globalAlignmentLoss(const torch::Tensor& src_transformed, const torch::Tensor& tgt,
                                  double c) {
  const auto d2 = pairwiseSquaredDistance(src_transformed, tgt);  // B×N×M squared distances
  // Summed over the points (not averaged): ϑ's slope is at most c, so a mean over ~10³ points
  // would leave L_g orders of magnitude below L_n and L_s in the unweighted total.
  const auto src_to_tgt = huber(d2.amin(2), c).sum(1);  // B
  const auto tgt_to_src = huber(d2.amin(1), c).sum(1);  // B
  return (src_to_tgt + tgt_to_src).mean();
}

torch::Tensor pointToPlaneAlignmentLoss(const torch::Tensor& src_transformed,
                                        const torch::Tensor& surface, const torch::Tensor& normals,
                                        double c) {
  OBM_ASSERT(src_transformed.dim() == 3 && surface.dim() == 3 &&
                 surface.sizes() == normals.sizes() && surface.size(0) == src_transformed.size(0),
             "pointToPlaneAlignmentLoss expects src B×3×N, surface and normals B×3×S");
  torch::Tensor nearest;
  {
    torch::NoGradGuard ng;
    nearest = pairwiseSquaredDistance(src_transformed, surface).argmin(2);  // B×N
  }
  const int64_t B = src_transformed.size(0), N = src_transformed.size(2);
  const auto idx = nearest.unsqueeze(1).expand({B, 3, N});
  const auto q = surface.gather(2, idx);
  const auto n = normals.gather(2, idx);
  const auto r = ((src_transformed - q) * n).sum(1).abs();  // B×N plane distances
  // Huber of the distance itself with the threshold √c (c is the threshold of the squared
  // distances of the point form), averaged like L_n: ϑ of the squared distance would be ~d⁴ below
  // c, with a gradient orders of magnitude under L_n's and L_s's at metre-level errors.
  return huber(r, std::sqrt(c)).mean();
}

torch::Tensor selectKeypoints(const torch::Tensor& weights, int64_t n) {
  OBM_ASSERT(weights.dim() == 2 && n >= 1, "selectKeypoints expects weights B×N and n >= 1");
  const int64_t k = std::min<int64_t>(n, weights.size(1));
  return std::get<1>(weights.detach().topk(k, /*dim=*/1, /*largest=*/true, /*sorted=*/true));
}

torch::Tensor neighborhoodLoss(const torch::Tensor& src, const torch::Tensor& tgt,
                               const torch::Tensor& pseudo_tgt, const RigidTransforms& T,
                               const torch::Tensor& keypoints, int64_t k, bool nearest) {
  OBM_ASSERT(src.sizes() == pseudo_tgt.sizes(), "neighborhoodLoss: src and pseudo-target differ");
  OBM_ASSERT(keypoints.dim() == 2 && keypoints.size(0) == src.size(0),
             "neighborhoodLoss: keypoints must be B×K");
  const int64_t B = src.size(0), K = keypoints.size(1);
  const int64_t k_src = std::min<int64_t>(k, src.size(2)),
                k_tgt = std::min<int64_t>(k, tgt.size(2));
  const int64_t kk = std::min(k_src, k_tgt);
  const auto kp3 = keypoints.unsqueeze(1).expand({B, 3, K});
  const auto x = src.gather(2, kp3);         // B×3×K keypoints in the source
  const auto y = pseudo_tgt.gather(2, kp3);  // B×3×K their pseudo-correspondences
  // Neighbour indices (nearest first): of x_i among the source, of y_i among the target.
  const auto nx = knnIndices(x.detach(), src.detach(), kk);  // B×K×kk
  const auto ny = knnIndices(y.detach(), tgt.detach(), kk);
  const auto P = gatherNeighbors(src, nx).reshape({B, 3, K * kk});
  const auto Q = gatherNeighbors(tgt, ny).reshape({B, 3, K * kk});
  const auto TP = transformPoints(T, P);
  if (nearest) {
    // Per keypoint, the kk×kk distances between its moved source neighbours and its target
    // neighbours: (B·K)×kk×kk.
    const auto a = TP.reshape({B, 3, K, kk}).permute({0, 2, 3, 1}).reshape({B * K, kk, 3});
    const auto b = Q.reshape({B, 3, K, kk}).permute({0, 2, 3, 1}).reshape({B * K, kk, 3});
    const auto d2 = (a.unsqueeze(2) - b.unsqueeze(1)).pow(2).sum(3);
    const auto d_ab = (d2.amin(2) + 1e-12).sqrt();  // each source neighbour → nearest target
    const auto d_ba = (d2.amin(1) + 1e-12).sqrt();  // each target neighbour → nearest source
    return 0.5 * (d_ab.mean() + d_ba.mean());
  }
  const auto r = TP - Q;
  // A tiny offset keeps the gradient of the norm finite at an exact match.
  return (r.pow(2).sum(1) + 1e-12).sqrt().mean();
}

torch::Tensor spatialConsistencyLoss(const torch::Tensor& log_match,
                                     const torch::Tensor& keypoints) {
  OBM_ASSERT(log_match.dim() == 3 && keypoints.dim() == 2 && keypoints.size(0) == log_match.size(0),
             "spatialConsistencyLoss expects log M^r B×N×M and keypoints B×K");
  const int64_t B = log_match.size(0), K = keypoints.size(1), M = log_match.size(2);
  const auto rows = log_match.gather(1, keypoints.unsqueeze(2).expand({B, K, M}));  // B×K×M
  return -rows.amax(2).mean();
}

torch::Tensor poseLabelLoss(const torch::Tensor& R, const torch::Tensor& t,
                            const torch::Tensor& R_label, const torch::Tensor& t_label,
                            const torch::Tensor& src) {
  OBM_ASSERT(R.dim() == 3 && R.sizes() == R_label.sizes() && t.sizes() == t_label.sizes() &&
                 src.dim() == 3 && src.size(0) == R.size(0),
             "poseLabelLoss expects R, R* B×3×3, t, t* B×3 and src B×3×N");
  // (R − R*) p + (t − t*): B×3×N residuals of the moved source points.
  const auto r = torch::matmul(R - R_label, src) + (t - t_label).unsqueeze(2);
  return (r.pow(2).sum(1) + 1e-12).sqrt().mean(1).mean();
}

torch::Tensor correspondenceLoss(const torch::Tensor& logits, const torch::Tensor& labels,
                                 double contrast) {
  OBM_ASSERT(logits.dim() == 3 && labels.dim() == 2 && labels.size(0) == logits.size(0) &&
                 labels.size(1) == logits.size(1) && labels.scalar_type() == torch::kInt64,
             "correspondenceLoss expects logits B×N×M and int64 labels B×N");
  OBM_ASSERT(contrast >= 0.0, "correspondenceLoss: contrast must be >= 0");
  OBM_ASSERT(labels.numel() == 0 || labels.max().item<int64_t>() < logits.size(2),
             "correspondenceLoss: a label is outside the target");
  auto z = logits;
  if (contrast > 0.0) {
    const auto mean = z.mean(2, /*keepdim=*/true);
    const auto sd = (z - mean).pow(2).mean(2, /*keepdim=*/true).add(1e-12).sqrt();
    z = contrast * (z - mean) / sd;
  }
  const auto log_p = torch::log_softmax(z, 2);
  const auto valid = labels >= 0;
  const auto picked = log_p.gather(2, labels.clamp_min(0).unsqueeze(2)).squeeze(2);  // B×N
  const auto n = valid.sum().clamp_min(1).to(logits.scalar_type());
  return -(picked * valid.to(logits.scalar_type())).sum() / n;
}

}  // namespace obm::obmnet
