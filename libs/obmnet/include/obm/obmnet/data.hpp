#pragma once
/// \file data.hpp
/// Registration pairs for training and evaluation (docs/obm-bench.md, "Pairs"), free of LibTorch:
/// the object set split, the pair protocols (clean, jitter, RIENet's outliers, partial crops),
/// and the pair normalisation shared by the trainer and the inference API.
#include <cstdint>
#include <functional>
#include <random>
#include <string>
#include <vector>

#include "obm/core/point_cloud.hpp"
#include "obm/core/se3.hpp"

namespace obm {

class ConfigNode;

namespace obmnet {

/// Where an object goes. Decided by a hash of its name, so the split is the same on every
/// machine and does not change when objects are added or removed.
enum class Split { Train, Validation, Test };

/// "train" / "val" / "test".
std::string splitName(Split s);

/// FNV-1a 64-bit hash of `name` mapped to [0, 1): < test_fraction → Test, < test + val →
/// Validation, else Train.
Split splitForName(const std::string& name, double val_fraction, double test_fraction);

/// How a pair (source, target) is made from one cloud (docs/obm-bench.md, "Pairs").
struct PairProtocol {
  /// Points drawn from the object's cloud for both source and target (the *same* points, as in
  /// DCP/RIENet's ModelNet40 protocol).
  int num_points = 1024;
  /// Independent samplings: source and target take *disjoint* random subsets of `num_points` of
  /// the object's cloud, which must then hold at least 2·num_points i.i.d. surface samples (the
  /// object set's `keep_points: 2048`). Two halves of one i.i.d. area-weighted sample are two
  /// independent samplings of the surface: no point is shared, as between two real scans.
  bool resample = false;
  /// Rotation: each Euler angle ~ U[0, max_angle_deg] with R = Rx·Ry·Rz (RIENet), or, with
  /// `axis_angle`, a uniform axis and angle ~ U[0, max_angle_deg] (ICL-NUIM protocol).
  double max_angle_deg = 45.0;
  bool axis_angle = false;
  /// Translation: each component ~ U[−max_translation, max_translation] (or, with `axis_angle`,
  /// a uniform direction with norm ~ U[0, max_translation]) [cloud units].
  double max_translation = 0.5;
  /// Partial crop: each cloud independently keeps its `partial_keep` points nearest to a random
  /// point far away (direction uniform on the sphere, distance `partial_far`). 0 = no crop.
  int partial_keep = 0;
  double partial_far = 500.0;
  /// Per-point Gaussian jitter σ, clipped at ±jitter_clip, drawn independently for source and
  /// target [cloud units]. 0 = none.
  double jitter_sigma = 0.0;
  double jitter_clip = 0.05;
  /// Draw each pair's σ uniformly from [0, jitter_sigma] (clip scaled with it): a training mix
  /// of noise levels, so that a batch always holds pairs the current features can still match.
  bool jitter_uniform = false;
  /// RIENet's "noise": this many outliers appended to each cloud, uniform in [−1, 1]³ plus
  /// N(0, 0.5²) and clipped to ±1.
  int outliers = 0;

  /// A named preset: clean, jitter, outliers, partial (768 of 1024, RIENet), partial_noise
  /// (640 of 1024 with σ = 0.01 jitter: overlap ≈ 0.65), indoor (7Scenes fragments: 2048 → 1536),
  /// icl (axis-angle ≤ 45°, ‖t‖ ≤ 0.5), resampled (independent samplings of 1024 points each,
  /// each cropped to 768 around its own far point, σ = 0.005 jitter). Throws ConfigError for an
  /// unknown name.
  static PairProtocol preset(const std::string& name);
  /// Reads `preset` (optional, applied first) then the individual keys. Unknown keys rejected.
  static PairProtocol load(const ConfigNode& node);
};

/// One registration problem: find T_target_source with target ≈ T_target_source · source.
struct RegistrationPair {
  PointCloud source;
  PointCloud target;
  Isometry3d T_target_source = Isometry3d::Identity();  ///< ground truth (evaluation only)
  /// Fraction of the source points whose original point is also in the target (1 without crop);
  /// with independent samplings, the fraction of source points inside the target's crop region.
  double overlap = 1.0;
  std::string name;  ///< object name (or sequence/frame ids)
  /// A pose label that is *not* ground truth, for self-supervised training (train.
  /// pose_loss_weight): the relative pose of the two scans in the trajectory the mapping app
  /// estimated on the training sequence (`data.pose_labels`). Unset for every other pair.
  bool has_pose_label = false;
  Isometry3d T_target_source_label = Isometry3d::Identity();
  /// Denser samples of the target's surface with a unit normal each (sign arbitrary), in the
  /// target's frame, for the point-to-plane form of the global-alignment loss: two independent
  /// samplings share no point, so point-to-point distances keep a floor of about the sampling
  /// spacing at the true pose, while a source point's distance to the *plane* of its nearest
  /// target surface sample vanishes there. Empty unless the data source makes them
  /// (`data.surface_points`); never used at inference.
  PointCloud target_surface;
  std::vector<Vector3f> target_normals;
};

/// Makes a pair from `cloud` (already normalised, e.g. to the unit sphere): draws
/// `num_points` points (all if fewer), crops, transforms, jitters and adds outliers as `protocol`
/// asks. Deterministic for a given `rng` state.
RegistrationPair makePair(const PointCloud& cloud, const PairProtocol& protocol,
                          std::mt19937_64& rng);

/// A scan pair (KITTI (i, i+j) protocol): each scan voxelised at `voxel` [m], then `num_points`
/// random points kept; `T_target_source` is the true relative pose (e.g. from ground truth) — it
/// is only used to report errors, never for training.
/// With `voxel_keypoints`, the N points are voxel keypoints (voxelKeypoints) of the voxelised
/// scan instead of a random subset.
/// `surface_points` > 0 also fills `target_surface` / `target_normals` with that many voxel
/// keypoints of the voxelised target and their PCA normals (pcaNormals, 10 neighbours).
RegistrationPair makeScanPair(const PointCloud& source_scan, const PointCloud& target_scan,
                              const Isometry3d& T_target_source, double voxel, int num_points,
                              std::mt19937_64& rng, bool voxel_keypoints = false,
                              int surface_points = 0);

/// Unit surface normal of every point: the eigenvector of the smallest eigenvalue of the
/// covariance of its k nearest neighbours (itself included; brute force, for clouds of a few
/// thousand points). Sign arbitrary; a point with fewer than 3 neighbours gets +z.
std::vector<Vector3f> pcaNormals(const PointCloud& cloud, int k);

/// Voxel keypoints: `n` points of `cloud` that cover it evenly, so that two scans of the same
/// place give nearly the same points where random subsets of each would share none. The cloud is
/// put on the coarsest cubic grid that still has at least `n` occupied cells (the cell size found
/// by bisection on a log scale), each cell gives the centroid of its points, and `n` of the cells
/// are kept at random when there are more. `indices` (optional) receives, per keypoint, the input
/// point nearest to it. Clouds of at most `n` points are returned whole.
PointCloud voxelKeypoints(const PointCloud& cloud, std::size_t n, std::mt19937_64& rng,
                          std::vector<std::size_t>* indices = nullptr);

/// Replaces every point by the mean of itself and its k nearest neighbours (Euclidean, brute
/// force: meant for the network's ≤ 2048-point clouds). Per-point jitter of σ drops to about
/// σ/√(k+1) while the surface is blurred by about the sampling spacing — the same blur in both
/// clouds of a pair, and the operation commutes with rigid motions, so the relative pose is
/// unchanged. k = 0 returns the cloud as is.
PointCloud neighbourMean(const PointCloud& cloud, int k);

/// The normalisation applied to a pair before the network sees it, identical in training and at
/// inference: each cloud is centred on its own centroid (or both on the target's, `shared`) and
/// both are scaled by one factor s so that the farther of the two is within radius `radius` (the
/// geometry of the training data).
/// Undo: T_target_source = T(c_t) · S⁻¹ · T̂ · S · T(−c_s).
struct PairNormalization {
  Eigen::Vector3d centroid_source = Eigen::Vector3d::Zero();
  Eigen::Vector3d centroid_target = Eigen::Vector3d::Zero();
  double scale = 1.0;  ///< s: normalised = s · (p − c)

  /// Computes the normalisation of (source, target) for the given radius (e.g. 1 for objects).
  /// `shared`: one centre for both clouds (ObmNetConfig::shared_centroid).
  static PairNormalization compute(const PointCloud& source, const PointCloud& target,
                                   double radius, bool shared = false);
  /// Applies it (in place) to a source / target cloud.
  void applySource(PointCloud& c) const;
  void applyTarget(PointCloud& c) const;
  /// T_target_source of the original clouds from the one estimated on the normalised clouds.
  Isometry3d denormalize(const Isometry3d& T_normalized) const;
  /// The inverse: the transform the network should find for a known original T.
  Isometry3d normalize(const Isometry3d& T_target_source) const;
};

/// Draws one training pair for a (1-based) epoch; called with the trainer's generator (seeded per
/// epoch, so a resumed run sees the same pairs).
using PairSampler = std::function<RegistrationPair(std::mt19937_64& rng, int epoch)>;

}  // namespace obmnet
}  // namespace obm
