#pragma once
/// \file config.hpp
/// Hyper-parameters of the OBMNet model (network widths, neighbourhood sizes, NMM and loss margins,
/// ablation switches). Plain struct with in-class defaults (RIENet's ModelNet40 configuration, see
/// docs/model.md); loaded from YAML in exactly one place, `ObmNetConfig::load`.
#include <cstdint>
#include <string>

namespace obm {

class ConfigNode;
}  // namespace obm

namespace obm::obmnet {

/// Hyper-parameters of OBMNet. Distances are in the units of the (normalised) input clouds.
struct ObmNetConfig {
  /// Width D of the per-point features Φ_P, Φ_Q (output of the EdgeConv extractor).
  int emb_dims = 256;
  /// Width of the inlier-evaluation block (conv 3→dim→2·dim).
  int dim = 8;
  /// Neighbours per point for the EdgeConv graph, the inlier evaluation and L_n (self included).
  int k1 = 5;
  /// Neighbours per point used by neighbour map matching (NMM), source and target (self included).
  int k2 = 5;
  /// Number of keypoints (highest inlier weights) used by L_n and L_s.
  int n_keypoints = 256;
  /// K: independent Gumbel-softmax draws of the overlap sampler, per cloud.
  int n_samples = 64;
  /// Registration iterations; each re-extracts source features on the transformed source.
  int n_iters = 3;
  /// γ of NMM: M^e = exp(γ − S)·M (RIENet's `nn_margin`).
  double nn_margin = 0.7;
  /// c of the Huber function ϑ in L_g, applied to squared distances [units²] (RIENet's
  /// `loss_margin`).
  double loss_margin = 0.01;
  /// κ of the self-training term L_c (correspondenceLoss): its cross-entropy is taken over each
  /// row of the matching logits standardised to zero mean and unit deviation, times κ, so that it
  /// cannot be lowered by flattening the map (scaling the features down); 0 = over the map's own
  /// logits. Training only; no effect at inference.
  double match_contrast = 3.0;
  /// β of NMM: D_ij = (1/d_ij + β) / Σ_j (1/d_ij + β).
  double beta = 1e-6;
  /// Lower bound of the Gumbel-softmax temperature: τ = softplus(·) + tau_min.
  double tau_min = 0.1;
  /// Overlap sampling (OS): learnt π, τ, K Gumbel samples and overlap features fused before
  /// matching.
  bool use_overlap_sampling = true;
  /// Bias prediction (BP): α > 0 weighting the overlapping correspondences in the SVD (needs OS).
  bool use_bias_prediction = true;
  /// Neighbour map matching (NMM) refinement of the matching map; off = M^r = row-softmax(−M).
  bool use_nmm = true;
  /// Back-propagate through the NMM neighbourhood score S (memory and time heavy on a CPU); off =
  /// S is a constant factor of M^e in the backward pass (the forward pass is the same).
  bool nmm_score_grad = false;
  /// 4-DoF solve for gravity-aligned sensors (LiDAR on a car): the weighted Procrustes of step 8
  /// estimates yaw about z and a 3-D translation only (roll = pitch = 0), in closed form
  /// (weightedProcrustesYaw). Two free parameters fewer, and no roll/pitch error to learn.
  bool planar = false;
  /// Surface normals in the EdgeConv's edge features: each edge (i, j) sees [n_i, n_j − n_i,
  /// x_j − x_i] instead of x_j − x_i alone, n estimated per cloud from its `normal_neighbours`
  /// nearest points and turned away from the cloud's centroid. Two independent samplings of one
  /// surface place their points differently but agree on its normals, so these channels differ
  /// less between the two clouds of a real pair than the neighbour offsets do. Recorded with the
  /// weights. A model without them warm-starts one with them (the new input columns start at
  /// zero, so the warm-started network computes what it did before).
  bool edge_normals = false;
  /// Neighbours (self included) of the normal estimate of `edge_normals`.
  int normal_neighbours = 16;
  /// Input sampling at inference: voxel keypoints (obmnet::voxelKeypoints, the same cells in two
  /// scans of one place) instead of a random subset. Recorded with the weights so that inference
  /// samples as training did.
  bool voxel_keypoints = false;
  /// L_n in its nearest-neighbour form (neighborhoodLoss, `nearest`), for clouds that do not
  /// share their samples; false = RIENet's pairing by rank. Training only.
  bool neighbor_loss_nearest = false;
  /// Pair normalisation about one centre (the target's centroid) for both clouds, instead of
  /// each cloud about its own. Scans in their sensor frame: two sweeps a metre apart then start
  /// the network a metre off (the identity), where separate centroids start it at the offset of
  /// the two centroids, which moves with what enters and leaves the sensor's range (metres on a
  /// street). Recorded with the weights so that inference normalises as training did.
  bool shared_centroid = false;
  /// [m] LiDAR sweeps: the registrar drops the returns less than this above each cloud's fitted
  /// ground plane (obm::removeGround) before sampling; 0 = off. The road's scan rings move with
  /// the sensor, so they look alike in two sweeps metres apart and pull soft matches towards
  /// "not moved". Training pairs must be cut the same way (data.ground_band, checked by
  /// obm-train). Recorded with the weights.
  double ground_band = 0.0;
  /// The overlap sampler at inference: the relaxed draw softmax((log π + g)/τ) that training
  /// uses (with the eval-mode noise stream), instead of the one-hot draw one_hot(argmax(log π + g)).
  /// A network trained on the relaxed draws learns τ and the fusion on them; where τ grows, a
  /// relaxed draw is a blend of many points and a one-hot one a single point, and the overlap
  /// summaries, α and the matching features then differ between training and inference (measured
  /// with `obm-train --overfit`: 0.3° in train mode, 19° with one-hot draws, 0.7° with relaxed
  /// ones; docs/model.md, "Overlap sampling at inference"). Recorded with the weights.
  bool soft_inference_sampling = false;
  /// σ of a spatial prior on the matching map [normalised units]; 0 = off. Each matching logit
  /// gets −‖p_i − q_j‖² / (2σ²) with p_i the source point as the iterations so far moved it, so
  /// the soft correspondences of step 6 favour target points near their source point and a pass
  /// starts at the identity (the pose the pair is given in) and corrects it, as ICP does, with
  /// the features choosing among the nearby points. For pairs whose start is already close
  /// (consecutive frames of a sensor, scan to local map), where a network free to match across
  /// the whole cloud turns pairs that barely moved by tens of degrees. Recorded with the
  /// weights; an inference choice as well (ObmNetImpl::setSpatialPrior).
  double match_spatial_sigma = 0.0;
  /// Seed of the Gumbel noise. Training draws a fresh stream from it; every forward pass in eval
  /// mode re-seeds, so registering the same pair twice gives the same result.
  std::uint64_t seed = 0;

  /// Reads the keys of `node` (all optional; unknown keys are rejected) and validates the values.
  /// Throws ConfigError naming the file and key.
  static ObmNetConfig load(const ConfigNode& node);
  /// Validates ranges and flag combinations; throws ConfigError prefixed with `where`.
  void validate(const std::string& where = "ObmNetConfig") const;
  /// All keys as a YAML map (readable back with `load`), stored beside trained weights.
  std::string toYaml() const;
};

/// Settings of the self-training teacher (teacher.hpp; YAML `train.teacher:` map,
/// TrainConfig::teacher).
struct TeacherParams {
  /// Point-to-point ICP iterations from each start.
  int icp_iterations = 30;
  /// ICP keeps a correspondence only when the moved source point is within a gate of its nearest
  /// target point; the gate shrinks linearly from `initial_max_distance` (first iteration: a
  /// start tens of degrees off) to `max_distance` (last) [normalised units of the pair].
  double initial_max_distance = 0.5;
  double max_distance = 0.1;
  /// A source point's label is its nearest target point under the refined pose when that point is
  /// within this distance, else none (−1): points outside the overlap, and most points of a pair
  /// the teacher got wrong, carry no label [normalised units].
  double match_radius = 0.05;
  /// Also refine from the identity and keep, per pair, the start whose result has the higher
  /// fitness (share of source points within match_radius).
  bool from_identity = true;
  /// Point-to-plane ICP (target normals from each point's `normal_neighbours` nearest points)
  /// instead of point-to-point: two independent samplings of a surface never share a point, and
  /// the point-to-point residual of such a pair bottoms out at the sample spacing, where the
  /// point-to-plane one goes to zero; it also converges from farther away.
  bool point_to_plane = false;
  int normal_neighbours = 10;
  /// When > 0, every start (the network's, the identity's) is also tried turned by ± this angle
  /// about the x, y and z axes through the moved source's centroid: six more starts each, so a
  /// network estimate tens of degrees off still has a start inside ICP's basin [deg].
  double start_rotation_deg = 0.0;
  /// A pair whose best start aligns fewer than this share of its source points is left
  /// unlabelled: low fitness is where the teacher's pose is most often wrong (0 = label every
  /// pair).
  double min_fitness = 0.0;

  /// Reads the keys of `node` (all optional; unknown keys are rejected) and validates the values;
  /// throws ConfigError naming the file and key.
  static TeacherParams load(const ConfigNode& node);
};

}  // namespace obm::obmnet
