#pragma once
/// \file fragment_source.hpp
/// Indoor fragments for the object-level tools (obm-train, obm-bench): RIENet's 7Scenes
/// protocol builds its pairs from depth-camera fragments — each fragment centred and scaled so
/// that max|v| = 0.5, 2048 points, then the pose generator and a crop to 1536 points (the pair
/// preset `indoor`). A fragment here is `fragment_frames` consecutive depth frames of an RGB-D
/// sequence fused in the first frame's camera frame with the sequence's ground truth (one frame
/// needs none), on a voxel grid, then `keep_points` random points. The `data:` map of a config
/// with `source: rgbd`; the sequences may be TUM, ICL-NUIM, 7-Scenes or Redwood / Open3D folders
/// (real, or what obm-sim writes).
#include <cstdint>
#include <random>
#include <string>
#include <vector>

#include "obm/obmnet/object_set.hpp"
#include "obm/obmnet/data.hpp"

namespace obm {
class ConfigNode;
}

namespace obm::datasets {

struct RgbdFragmentOptions {
  /// Default layout of the sequences: tum | iclnuim | 7scenes | redwood. An entry of the lists
  /// below may name its own as a prefix, "redwood:PATH".
  std::string layout = "tum";
  /// Folders, relative to `dir` unless absolute; `$VAR/...` or `${VAR}/...` takes an environment
  /// variable (e.g. $OBM_SHARED_DATA).
  std::vector<std::string> train_sequences;
  std::vector<std::string> val_sequences;    ///< model selection
  std::vector<std::string> test_sequences;   ///< the unseen group of obm-bench
  int fragment_frames = 1;  ///< depth frames fused into one fragment (> 1 needs ground truth)
  int frame_step = 10;      ///< a fragment starts every frame_step frames
  int test_frame_step = 10;  ///< the same for the test sequences (default: frame_step)
  int stride = 2;           ///< every stride-th pixel row and column is back-projected
  double min_depth = 0.3;   ///< [m]
  double max_depth = 4.0;   ///< [m] (RGB-D depth is reliable to ~4 m)
  double voxel = 0.01;      ///< [m] voxel grid of the fused fragment, before the random sample
  double radius = 0.5;      ///< fragments are scaled so that max|v − centroid| = radius (RIENet's 7Scenes protocol)
  /// [min, max] frames between the two depth frames of a training pair (obm-train): when set,
  /// obm-train trains on pairs of two *different* frames (rgbdFramePairSampler) instead of one
  /// fragment cut twice; empty = fragments.
  std::vector<int> pair_gaps;
  /// Self-supervised pose labels of the frame pairs: a TUM trajectory file name (e.g.
  /// slam_groundtruth.txt) in each *training* sequence folder, written by obm-map on that
  /// sequence; read in place of the ground truth, it gives each pair the label of the pose loss
  /// L_p (train.pose_loss_weight). Empty = no labels (unsupervised). Needs pair_gaps.
  std::string pose_labels;
  /// [MAX_DEG, MAX_M]: each frame pair starts *near its answer* instead of where the two camera
  /// poses put it: the source is moved by Δ · T (startNearPose), with T the pair's pose label
  /// (training; needs pose_labels) or its ground truth (validation), Δ a random turn of up to
  /// MAX_DEG and shift of up to MAX_M metres. A network trained so learns a pass whose fixed
  /// point is the answer: started right (by a start turn, FGR, the motion model), it stays there.
  /// Empty = pairs as the walk gives them.
  std::vector<double> start_near_label;

  /// Reads the `rgbd:` map; unknown keys are errors naming the file.
  static RgbdFragmentOptions load(const ConfigNode& node);
};

/// Fragments of every sequence of `options`, keep_points points each (`objects.keep_points` of the
/// config), split by sequence: train / val / test. Fragments with fewer points after the voxel
/// grid are skipped with a warning; frame_id is "SEQUENCE:FRAME". Throws IoError naming the
/// folder when a sequence cannot be opened, FormatError when fusing frames without ground truth,
/// and IoError when the training split ends up empty.
obmnet::ObjectSet loadRgbdFragments(const std::string& dir, const RgbdFragmentOptions& options,
                                    int keep_points, std::uint64_t seed);

/// Pairs of two *different* depth frames of one sequence (no fragment cut twice): frames i and
/// j = i + s with s drawn from [min_gap, max_gap] (clamped to the sequence; a sequence shorter
/// than min_gap + 1 frames gives the pairs of its first and later frames), each back-projected
/// with the options' stride and depth range and put on the voxel grid, in metres, each in its own
/// camera frame; T_target_source = T_world_i⁻¹ · T_world_j from the sequence's poses (needed).
/// `n` pairs spread evenly over `sequences` (entries as in RgbdFragmentOptions) from `seed`;
/// name "SEQUENCE:j->i". With `with_colors`, each point keeps its pixel's colour (averaged on the
/// voxel grid) wherever the frame has a colour image, for coloured ICP; the pairs' geometry is the
/// same either way. Throws IoError / FormatError naming the folder.
std::vector<obmnet::RegistrationPair> rgbdFramePairs(const std::string& dir,
                                                     const RgbdFragmentOptions& options,
                                                     const std::vector<std::string>& sequences,
                                                     int min_gap, int max_gap, int n,
                                                     std::uint64_t seed, bool with_colors = false);

/// Training pairs of two different depth frames (the frame-pair counterpart of
/// scanPairSampler): a random training sequence (weighted by its frames), a gap s from
/// options.pair_gaps, a random first frame i, the pair (i + s → i), each frame back-projected,
/// put on the voxel grid and sampled to exactly `num_points` (drawn again when a frame has
/// fewer), in metres, each in its own camera frame. The sequences' poses, when present, are
/// attached as ground truth for reporting only; the losses never see them.
obmnet::PairSampler rgbdFramePairSampler(const std::string& dir,
                                         const RgbdFragmentOptions& options, int num_points);

/// Moves the pair's source by Δ · T_near (Δ: a turn of U[0, max_deg] degrees about a uniformly
/// random axis through the target frame's origin, then a shift of U[0, max_m] metres in a
/// uniformly random direction); T_target_source and, when set, the pose label follow, so both stay
/// the transform from the moved source to the target. With T_near = T_target_source the pair's
/// pose becomes Δ⁻¹: not moving is then max_deg / max_m from the answer at most (RRE / RTE).
/// The source's frame_id gets "@start".
void startNearPose(obmnet::RegistrationPair& pair, const Isometry3d& T_near, double max_deg,
                   double max_m, std::mt19937_64& rng);

/// `pairs` with each cloud sampled to exactly `num_points` from `seed` (as the sampler above
/// does), for validation pairs that batch like the training ones.
std::vector<obmnet::RegistrationPair> withPointCount(std::vector<obmnet::RegistrationPair> pairs,
                                                    int num_points, std::uint64_t seed);

}  // namespace obm::datasets
