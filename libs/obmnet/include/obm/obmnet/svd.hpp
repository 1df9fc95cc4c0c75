#pragma once
/// \file svd.hpp
/// Batched, differentiable weighted Procrustes (docs/model.md, step 8) and small SE(3) helpers
/// on B×3×3 / B×3 tensors.
#include <torch/torch.h>

#include "obm/core/se3.hpp"

namespace obm::obmnet {

/// A batch of rigid transforms T_a_b: p_a = R·p_b + t.
struct RigidTransforms {
  torch::Tensor R;  ///< B×3×3
  torch::Tensor t;  ///< B×3
};

/// Weighted least-squares rigid transform T_tgt_src mapping `src` onto `tgt` (both B×3×N,
/// column i of src corresponds to column i of tgt) with non-negative `weights` B×N (normalised
/// here, so any positive scale gives the same result). Weighted centroids x̄, ȳ;
/// H = Σ w_i (x_i − x̄)(y_i − ȳ)ᵀ = U S Vᵀ; R = V diag(1, 1, det(V Uᵀ)) Uᵀ (a proper rotation,
/// reflections excluded); t = ȳ − R x̄. Differentiable through torch::linalg_svd. A row whose
/// weights sum to at most `eps` (all vanished) is solved with uniform weights.
RigidTransforms weightedProcrustes(const torch::Tensor& src, const torch::Tensor& tgt,
                                   const torch::Tensor& weights, double eps = 1e-12);

/// The 4-DoF weighted Procrustes (yaw about z, translation): with a = x − x̄, b = y − ȳ the
/// weighted least-squares yaw is θ = atan2(Σ w (a_x b_y − a_y b_x), Σ w (a_x b_x + a_y b_y)), R =
/// Rz(θ), t = ȳ − R x̄. Closed form, so its gradient has none of the SVD's degenerate cases.
RigidTransforms weightedProcrustesYaw(const torch::Tensor& src, const torch::Tensor& tgt,
                                      const torch::Tensor& weights, double eps = 1e-12);

/// R·p + t for points B×3×N.
torch::Tensor transformPoints(const RigidTransforms& T, const torch::Tensor& points);

/// Composition T_a_c = T_a_b ∘ T_b_c: R = R_ab R_bc, t = R_ab t_bc + t_ab.
RigidTransforms compose(const RigidTransforms& T_a_b, const RigidTransforms& T_b_c);

/// Transform `i` of the batch (R B×3×3, t B×3) as an Isometry3d, in double.
Isometry3d toIsometry(const torch::Tensor& R, const torch::Tensor& t, int64_t i);

/// One transform as a batch of one (float32, row-major R as transformPoints expects).
RigidTransforms fromIsometry(const Isometry3d& T);

/// Identity transforms for a batch of `batch` on the given tensor options.
RigidTransforms identityTransforms(int64_t batch, const torch::TensorOptions& options);

}  // namespace obm::obmnet
