#pragma once
/// \file teacher.hpp
/// Self-training labels for OBMNet (docs/training.md "Self-training from the network's own
/// ICP-refined estimate"). No ground truth: each training pair is labelled by the network's
/// current estimate refined by point-to-point ICP on the pair itself, and the labels become
/// correspondences for the matching map (correspondenceLoss). Batched, on the model's tensors.
#include <torch/torch.h>

#include "obm/obmnet/config.hpp"
#include "obm/obmnet/svd.hpp"

namespace obm::obmnet {


/// ICP for a batch: `src` B×3×N, `tgt` B×3×M, starting from `T0`; each iteration pairs every
/// moved source point with its nearest target point, drops pairs farther apart than the
/// iteration's gate (linear from `initial_max_distance` to `max_distance`) and solves the rigid
/// transform of the kept pairs. Without `tgt_normals` the solve is point to point (weighted
/// Procrustes); with them (B×3×M unit normals, estimateNormals) it is point to plane: the
/// residual n·(R p + t − q) linearised in a small rotation ω and translation v, the 6×6 normal
/// equations solved per pair and the step applied as exp(ω). A pair with fewer kept points than
/// the solve needs (three; six for point to plane) keeps its previous transform. No gradient.
RigidTransforms icpRefine(const torch::Tensor& src, const torch::Tensor& tgt,
                          const RigidTransforms& T0, int iterations, double initial_max_distance,
                          double max_distance, const torch::Tensor& tgt_normals = {});

/// B×3×M unit normals of a batch of clouds B×3×M: per point, the direction of least spread of
/// its `k` nearest points (itself included). The sign is arbitrary: point-to-plane ICP does not
/// need it.
torch::Tensor estimateNormals(const torch::Tensor& points, int k);

/// B: the share of source points whose nearest target point is within `radius` after `T`.
torch::Tensor alignmentFitness(const torch::Tensor& src, const torch::Tensor& tgt,
                               const RigidTransforms& T, double radius);

/// B×N int64: for every source point, the index of its nearest target point after `T` when it is
/// within `radius`, else −1.
torch::Tensor correspondenceLabels(const torch::Tensor& src, const torch::Tensor& tgt,
                                   const RigidTransforms& T, double radius);

/// The teacher's labels for a batch: ICP (point to plane when `p.point_to_plane`) from the
/// network's estimate `T_net`, from the identity when `p.from_identity`, and from each of them
/// turned by ±`p.start_rotation_deg` about three axes when that is > 0; per pair the start whose
/// result labels the most source points wins (the first of equals, the network's first). Returns
/// the chosen transforms and, in `labels`, their correspondenceLabels — all −1 for a pair whose
/// share of labelled points is below `p.min_fitness`.
RigidTransforms teacherLabels(const torch::Tensor& src, const torch::Tensor& tgt,
                              const RigidTransforms& T_net, const TeacherParams& p,
                              torch::Tensor& labels);

}  // namespace obm::obmnet
