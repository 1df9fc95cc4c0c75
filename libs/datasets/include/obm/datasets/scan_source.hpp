#pragma once
/// \file scan_source.hpp
/// LiDAR scan pairs for obm-train (RIENet's KITTI protocol: pairs (i, i + frame_gap), each scan
/// on a voxel grid, then N random points): the `data:` map of a config with `source: kitti`.
/// The sequences are KITTI odometry folders — real ones or the ones obm-sim writes. Training never
/// reads their poses; validation scores against them, so validation sequences need ground truth.
#include <string>
#include <vector>

#include "obm/obmnet/data.hpp"

namespace obm {
class ConfigNode;
}

namespace obm::datasets {

struct ScanSourceConfig {
  /// Folder holding the sequences: a sequence name `s` is found as `dir/sequences/s` (the devkit
  /// layout), `dir/s`, or `s` itself when it is a path. Relative paths are taken from the
  /// working directory.
  std::string dir;
  std::vector<std::string> sequences;      ///< training sequences
  std::vector<std::string> val_sequences;  ///< validation sequences (need ground truth)
  int frame_gap = 10;                      ///< pairs (i, i + frame_gap)
  /// Training: the gap of each pair drawn uniformly from this list (empty = {frame_gap}), e.g.
  /// {1, 5, 10, 20}: consecutive sweeps up to ~20 m apart.
  std::vector<int> frame_gaps;
  double voxel = 0.3;                      ///< [m] voxel grid before the random N-point sample
  double min_range = 0.0;                  ///< [m] returns closer than this are dropped (0 = keep)
  double max_range = 0.0;                  ///< [m] returns farther than this are dropped (0 = keep)
  /// [m] drop the returns less than this above the sweep's fitted ground plane (removeGround);
  /// 0 = keep the road.
  double ground_band = 0.0;
  /// N points per scan as voxel keypoints (obmnet::voxelKeypoints) rather than a random subset.
  bool voxel_keypoints = false;
  /// Surface samples of each target (voxel keypoints of the voxelised sweep) with PCA normals, for
  /// the point-to-plane form of L_g (RegistrationPair::target_surface); 0 = none (L_g point to
  /// point against the target's N points, as in the paper).
  int surface_points = 0;
  /// Loop pairs: two sweeps at least `loop_min_separation` sweeps apart whose positions are within
  /// `loop_max_distance` [m] horizontally (a revisit, in any direction). Finding them needs the
  /// positions of the sweeps (poses.txt; any odometry or GNSS track would do): they choose which
  /// sweeps are paired and never enter the loss.
  double loop_fraction = 0.0;  ///< training: share of loop pairs (0 = none)
  double loop_max_distance = 10.0;
  int loop_min_separation = 100;
  /// Training: the source sweep is turned by a random yaw in ±yaw_augment_deg about the sensor's
  /// z axis (a made-up heading change, so revisits from any direction are covered; no ground
  /// truth involved).
  double yaw_augment_deg = 0.0;
  /// Self-supervised pose labels: a file name inside each *training* sequence's folder holding
  /// the trajectory the mapping app estimated on it (obm-map's trajectory_kitti.txt, camera-0
  /// poses in the convention of poses.txt). When set, the training pairs and the loop search read
  /// their poses from it, never from poses.txt, and each pair carries its relative pose as a label
  /// (RegistrationPair::T_target_source_label, for train.pose_loss_weight). Validation sequences
  /// keep their ground truth, which only scores.
  std::string pose_labels;
  /// With pose labels: the yaw hypotheses of inference (4 for `planar` models, 90° apart). Each
  /// labelled pair's source is turned by the hypothesis nearest to its labelled heading (after
  /// the yaw augmentation), so the network trains on residual headings within ±180°/H, which is
  /// what it meets at inference; 0 = off (any heading, up to 180°).
  int label_yaw_hypotheses = 0;

  /// Reads the `data:` map (source must be `kitti`); unknown keys are errors naming the file.
  static ScanSourceConfig load(const ConfigNode& node);
};

/// Training pairs: a random sequence (weighted by its number of pairs), a random i, the pair
/// (i + gap → i), both scans cropped, voxelised and sampled to `num_points` by makeScanPair.
/// Ground truth, when the sequence has it, is only attached for reporting. Throws IoError /
/// FormatError naming the folder when a sequence cannot be opened or is shorter than the gap.
///
/// Curriculum (`curriculum_epochs` > 0), the scan counterpart of the object curriculum: two
/// sweeps sampled independently share no point, and a fresh network cannot match them; the same
/// sampled points moved by a random motion can be matched at once. In epoch e a pair is such a
/// self-pair with probability 1 − (e − 1)/curriculum_epochs (the motion: yaw ≤ 10°, roll/pitch
/// ≤ 1°, ≤ 10 m horizontally, like (i, i+10) at urban speed), else a real (i, i + gap) pair.
/// No ground truth is used either way: the self-pair's motion is made up, not measured.
obmnet::PairSampler scanPairSampler(const ScanSourceConfig& config, int num_points,
                                    int curriculum_epochs = 0);

/// Which pairs of a sequence: (i, i + gap) or loop pairs (revisits, see ScanSourceConfig).
struct ScanPairClass {
  int gap = 10;       ///< frame gap; ignored for loops
  bool loop = false;  ///< revisit pairs, spread evenly over the yaw difference 0–180°
  std::string label() const { return loop ? "loop" : "k" + std::to_string(gap); }
  /// "k10" / "10" → gap 10, "loop" → loops. Throws ConfigError otherwise.
  static ScanPairClass parse(const std::string& s);
};

/// `n` fixed validation pairs, evenly spread over the validation sequences, from `seed`. Throws
/// IoError naming the folder when a validation sequence has no ground truth.
std::vector<obmnet::RegistrationPair> scanValidationPairs(const ScanSourceConfig& config,
                                                          int num_points, int n,
                                                          std::uint64_t seed);
/// The same for one pair class (loop pairs: evenly over six 30° bins of yaw difference, then
/// along the sequences). Throws Error when a sequence holds no pair of the class.
std::vector<obmnet::RegistrationPair> scanPairs(const ScanSourceConfig& config,
                                                const std::vector<std::string>& sequences,
                                                const ScanPairClass& cls, int num_points, int n,
                                                std::uint64_t seed);

}  // namespace obm::datasets
