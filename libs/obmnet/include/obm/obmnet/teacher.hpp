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


/// Point-to-point ICP for a batch: `src` B×3×N, `tgt` B×3×M, starting from `T0`; each iteration
/// pairs every moved source point with its nearest target point, drops pairs farther apart than
/// the iteration's gate (linear from `initial_max_distance` to `max_distance`) and solves the
/// rigid transform of the kept pairs (weighted Procrustes). A pair with fewer than three kept
/// points keeps its previous transform. No gradient.
RigidTransforms icpRefine(const torch::Tensor& src, const torch::Tensor& tgt,
                          const RigidTransforms& T0, int iterations, double initial_max_distance,
                          double max_distance);

/// B: the share of source points whose nearest target point is within `radius` after `T`.
torch::Tensor alignmentFitness(const torch::Tensor& src, const torch::Tensor& tgt,
                               const RigidTransforms& T, double radius);

/// B×N int64: for every source point, the index of its nearest target point after `T` when it is
/// within `radius`, else −1.
torch::Tensor correspondenceLabels(const torch::Tensor& src, const torch::Tensor& tgt,
                                   const RigidTransforms& T, double radius);

/// The teacher's labels for a batch: ICP from the network's estimate `T_net` (and from the
/// identity when `p.from_identity`), the better start per pair by fitness; returns the chosen
/// transforms and, in `labels`, their correspondenceLabels.
RigidTransforms teacherLabels(const torch::Tensor& src, const torch::Tensor& tgt,
                              const RigidTransforms& T_net, const TeacherParams& p,
                              torch::Tensor& labels);

}  // namespace obm::obmnet
