#pragma once
/// \file losses.hpp
/// The unsupervised losses of RIENet / OBMNet (docs/model.md "Unsupervised losses"). None of them uses
/// ground truth: they compare the transformed source with the target and with the pseudo-target.
#include <torch/torch.h>

#include "obm/obmnet/svd.hpp"

namespace obm::obmnet {

/// Huber function ϑ on non-negative x: 0.5·x² if x < c, else c·x − 0.5·c² (continuous, C¹ at c).
torch::Tensor huber(const torch::Tensor& x, double c);

/// L_g global alignment: ϑ of the *squared* nearest-neighbour distance, summed over the points,
/// in both directions (transformed source → target and target → transformed source), summed over
/// the two directions and averaged over the batch. `src_transformed` B×3×N, `tgt` B×3×M.
torch::Tensor globalAlignmentLoss(const torch::Tensor& src_transformed, const torch::Tensor& tgt,
                                  double c);

/// L_g in point-to-plane form, for independent samplings: for every transformed source point p,
/// its nearest sample q of the target's surface (`surface` B×3×S, denser than the keypoints) with
/// unit normal n (`normals` B×3×S), and ϑ, with threshold √c, of the distance |nᵀ(p − q)| to that
/// plane, averaged over the points and the batch (one direction: the source's normals are not
/// known). The mean of a distance, like L_n, so that its gradient is of the size of the other
/// terms' (ϑ of the *squared* distance, as in the point form, is ~d⁴ at small errors). At the true pose the point-to-point distance keeps a floor of about the sampling
/// spacing; the distance to the plane does not, so the minimum of this loss is the true pose.
/// The nearest sample is chosen without gradient; the gradient flows through p.
torch::Tensor pointToPlaneAlignmentLoss(const torch::Tensor& src_transformed,
                                        const torch::Tensor& surface, const torch::Tensor& normals,
                                        double c);

/// Indices (B×K, int64) of the K = min(n, N) highest `weights` (B×N): the keypoints of L_n, L_s.
torch::Tensor selectKeypoints(const torch::Tensor& weights, int64_t n);

/// L_n neighbourhood agreement (docs/model.md, RIENet): for every keypoint i, x_i = p_{κ_i} of the
/// source and y_i = q'_{κ_i} its pseudo-correspondence; N(x_i) are the k nearest source points of
/// x_i and N(y_i) the k nearest *target* points of y_i, both sorted by distance, and the j-th
/// neighbours are paired: mean over keypoints, neighbours and batch of ‖R p_j + t − q_j‖.
/// A neighbourhood that moves rigidly with its keypoint agrees; one that does not (an outlier
/// keypoint, a wrong match) is penalised without any ground truth.
/// `src` B×3×N (the cloud `T` applies to), `tgt` B×3×M, `pseudo_tgt` B×3×N, `keypoints` B×K.
/// `nearest`: the form for independently sampled clouds. Pairing by rank assumes that the j-th
/// neighbour of x_i and the j-th neighbour of y_i are the same surface point, which holds only
/// when both clouds carry the same samples (RIENet's pairs); two scans never do, and the rank
/// pairs are then a sampling spacing apart in random directions at the true pose. Instead each
/// moved source neighbour is paired with its nearest target neighbour of y_i and each target
/// neighbour with its nearest moved source neighbour (a Chamfer distance between the two
/// neighbourhoods, the mean of both directions), which vanishes at the true pose as the sampling
/// gets dense, whatever the samples.
torch::Tensor neighborhoodLoss(const torch::Tensor& src, const torch::Tensor& tgt,
                               const torch::Tensor& pseudo_tgt, const RigidTransforms& T,
                               const torch::Tensor& keypoints, int64_t k, bool nearest = false);

/// L_s spatial consistency: −log M^r_ij at each keypoint's row argmax j, averaged over keypoints
/// and batch. `log_match` is log M^r (B×N×M, from log-softmax for accuracy), `keypoints` B×K.
torch::Tensor spatialConsistencyLoss(const torch::Tensor& log_match,
                                     const torch::Tensor& keypoints);

/// L_p, the pose-label term of self-supervised training (not one of the paper's losses): the mean
/// over the batch and the source points p of ‖(R p + t) − (R* p + t*)‖, with (R, t) the estimate
/// (B×3×3, B×3), (R*, t*) the label and `src` the normalised source (B×3×N). A distance on the
/// points rather than on the parameters weighs rotation by the cloud's extent, as L_g does.
torch::Tensor poseLabelLoss(const torch::Tensor& R, const torch::Tensor& t,
                            const torch::Tensor& R_label, const torch::Tensor& t_label,
                            const torch::Tensor& src);

/// L_c, the correspondence term of self-training (not one of the paper's losses; teacher.hpp):
/// −log softmax(ẑ)_{i, j*} for every source point i whose label j* (B×N int64, −1 = none) is set,
/// averaged over the labelled points of the batch; 0 when none is. `logits` B×N×M are the
/// matching map's logits (M^r = softmax(logits) by rows). With `contrast` κ > 0,
/// ẑ = κ·(z − mean_j z)/std_j z per row: a cross-entropy invariant to the scale of the logits.
/// On the raw logits (κ = 0) a row whose label is far from its mode is cheapest to fix by
/// flattening every row (shrinking the features), which undoes the sharp matches L_s asks for and
/// pulls the pseudo-targets to the centroids; on the standardised ones only the order and spacing
/// of the logits count. A cross-entropy asks the row to put its mass on the labelled point
/// itself, which the global-alignment and neighbourhood terms only ask of the centroid M^r·Q.
torch::Tensor correspondenceLoss(const torch::Tensor& logits, const torch::Tensor& labels,
                                 double contrast = 0.0);

}  // namespace obm::obmnet
