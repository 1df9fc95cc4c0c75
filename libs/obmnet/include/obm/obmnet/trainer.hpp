#pragma once
/// \file trainer.hpp
/// Unsupervised training of OBMNet (docs/training.md: Adam, step schedule, losses L_g + L_n + L_s).
/// Ground truth is never used to train; it only scores the validation split, on which the best
/// checkpoint is chosen (never on the test split). LibTorch stays out of this header.
#include <array>
#include <cstdint>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "obm/core/point_cloud.hpp"
#include "obm/obmnet/config.hpp"
#include "obm/obmnet/data.hpp"

namespace obm {

class ConfigNode;

namespace obmnet {

class ProcessGroup;

/// Everything a training run needs besides the data. Loaded from the `train:` and `model:` maps of
/// a YAML file in `TrainConfig::load`; see config/obmnet/*.yaml.
struct TrainConfig {
  ObmNetConfig model;         ///< network hyper-parameters (`model:` map)
  PairProtocol protocol;      ///< training pairs (`train.pairs:` map)
  PairProtocol val_protocol;  ///< validation pairs (`train.val_pairs:`; default = protocol)
  int batch_size = 16;
  int epochs = 50;
  int pairs_per_epoch = 1600;  ///< pairs drawn per epoch (objects drawn with replacement)
  int val_pairs = 200;         ///< fixed validation pairs (same every epoch)
  double lr = 1e-3;            ///< Adam learning rate
  double weight_decay = 1e-4;
  std::vector<int> lr_steps{25};  ///< epochs (1-based, at their start) where lr ×= lr_gamma
  double lr_gamma = 0.7;
  double normalize_radius = 1.0;  ///< pair normalisation radius (PairNormalization)
  double recall_deg = 1.0;        ///< validation recall: MIE(R) below this ...
  double recall_trans = 0.05;     ///< ... and MIE(t) below this [normalised units]
  /// Validation inlier ratio: a source point's most probable target point (last iteration) is a
  /// correct match when it lies within this distance of the source point moved by the true pose
  /// [units of the pairs: 0.1 for unit-sphere objects and metric indoor fragments; ~1 m suits
  /// LiDAR keypoints]. It scores the features' matching, apart from the pose solve.
  double inlier_radius = 0.1;
  double max_grad_norm = 10.0;    ///< gradient clipping (0 = off)
  int threads = 2;                ///< intra-op threads (torch::set_num_threads)
  std::uint64_t seed = 1;         ///< seeds weights, pair generation and Gumbel noise
  double max_hours = 0.0;         ///< stop (with a checkpoint) after this wall time; 0 = no limit
  /// Also write every epoch's model as OUT/epoch_NNN.pt. best.pt is chosen on the validation
  /// pairs, whose mean rotation error over a few dozen pairs moves by several degrees between
  /// draws of the pairs; keeping every epoch lets a larger benchmark choose instead.
  bool save_epochs = false;
  /// Epochs over which the training pairs go from clean to `protocol` (crop and jitter ramped up
  /// linearly; see curriculumProtocol). Learning to match from scratch on partial, noisy pairs
  /// is slow; on identical points it is immediate, and the features carry over.
  int curriculum_epochs = 0;
  /// Level of the curriculum at epoch 1, in [0, 1): 0 = clean pairs; e.g. 0.4 starts a
  /// warm-started model at 40 % of the target's jitter and crop, where it still matches.
  double curriculum_start = 0.0;

  /// Weight of the pose-label term L_p (self-supervision, not part of the paper's losses): the
  /// mean distance, on the normalised source, between the points moved by the estimate and by
  /// the pair's pose label (RegistrationPair::T_target_source_label: the mapping app's own
  /// trajectory of the training sequence, never ground truth). 0 = the paper's unsupervised
  /// L_g + L_n + L_s only. > 0 needs every training pair to carry a label.
  double pose_loss_weight = 0.0;
  /// Self-training (not one of the paper's losses; docs/training.md): before every step the
  /// network's own estimate of each training pair, refined by point-to-point ICP on the pair
  /// (and, when `teacher.from_identity`, ICP from the identity, the better fit kept), labels every
  /// source point with its nearest target point within `teacher.match_radius`; the weighted
  /// correspondence term match_loss_weight·L_c is added to the loss. No ground truth: the labels
  /// are the network's and ICP's. 0 = off; > 0 needs a `train.teacher:` map.
  double match_loss_weight = 0.0;
  TeacherParams teacher;  ///< the teacher's settings (`train.teacher:` map)
  /// Weights of L_g, L_n, L_s in the training objective (YAML `loss_weights: [g, n, s]`); the
  /// paper's sum is {1, 1, 1}. A diagnostic of which term leads where (obm-train --overfit); the
  /// validation loss stays the unweighted sum.
  std::array<double, 3> loss_weights{1.0, 1.0, 1.0};
  /// The training objective of a forward pass: the weighted L_g + L_n + L_s (o.loss itself
  /// when the weights are the paper's, so that runs without the key are bit-identical).
  bool paperLossWeights() const {
    return loss_weights[0] == 1.0 && loss_weights[1] == 1.0 && loss_weights[2] == 1.0;
  }
  /// The validation score that chooses best.pt (lower is better).
  enum class Selection { MieR, MieT };
  Selection select_on = Selection::MieR;

  /// Where the network trains: "cpu" or "cuda:K" (a LibTorch build with CUDA; checked at load).
  std::string device = "cpu";
  static TrainConfig load(const ConfigNode& root);
};

/// One row of the training log (also written to train_log.csv).
struct EpochStats {
  int epoch = 0;
  double lr = 0.0;
  double loss = 0.0, loss_global = 0.0, loss_neighbor = 0.0, loss_spatial = 0.0;
  double loss_pose = 0.0;  ///< weighted L_p (0 without pose labels); included in `loss`
  double loss_match = 0.0;  ///< weighted L_c of self-training (0 without); included in `loss`
  /// Self-training: mean share of the source points the teacher labelled (0 without).
  double teacher_labelled = 0.0;
  double val_loss = 0.0, val_mie_r = 0.0, val_mie_t = 0.0, val_recall = 0.0, val_mean_alpha = 0.0;
  double val_inlier_ratio = 0.0;  ///< ValidationScores::inlier_ratio
  double pairs_per_s = 0.0;
  double wall_s = 0.0;  ///< cumulated training wall time at the end of this epoch
  /// Data-parallel runs: mean time per step spent in the collectives (gradient all-reduce,
  /// buffer broadcast, loss and stop-flag reductions) [ms]; 0 for a single process.
  double comm_ms_per_step = 0.0;
  bool best = false;
};

/// Validation scores of a model on a list of pairs.
struct ValidationScores {
  double loss = 0.0, mie_r = 0.0, mie_t = 0.0, recall = 0.0, mean_alpha = 0.0;
  /// Mean over the pairs of the share of source points whose most probable target point (the
  /// network's last iteration) lies within TrainConfig::inlier_radius of where the true pose puts
  /// the source point: the correspondence inlier ratio, the usual measure of a matcher's features.
  double inlier_ratio = 0.0;
  /// Self-training only (TrainConfig::match_loss_weight > 0), the teacher on the same pairs,
  /// scored against ground truth (which it never sees): the mean share of source points it
  /// labels, the share of those labels that are correct matches (within inlier_radius of the true
  /// position), and the rotation error of its refined pose [deg]. 0 without self-training.
  double teacher_labelled = 0.0, teacher_precision = 0.0, teacher_mie_r = 0.0;
};

/// Trains a model into `out_dir`:
///   checkpoint.pt   model + optimiser + epoch (resume point, written after every epoch)
///   best.pt         best model on the validation split (a model file for loadModel)
///   train_log.csv   one row per epoch
///   config.yaml     the configuration actually used

/// The protocol of epoch `epoch` under a curriculum of `curriculum_epochs` epochs: the crop and the
/// jitter grow linearly from none (a clean pair) to `target`'s, reached at epoch
/// `curriculum_epochs` and kept afterwards. 0 epochs = `target` from the start.
PairProtocol curriculumProtocol(const PairProtocol& target, int epoch, int curriculum_epochs,
                                double curriculum_start = 0.0);

/// The sampler of the object-level protocols: a random cloud of `clouds`, made into a pair by
/// `protocol` (makePair), eased by curriculumProtocol during the first `curriculum_epochs`.
PairSampler objectPairSampler(std::vector<PointCloud> clouds, PairProtocol protocol,
                              int curriculum_epochs = 0, double curriculum_start = 0.0);

/// `n` validation pairs from `clouds` (cycled) with `protocol`, from a fixed seed.
std::vector<RegistrationPair> objectValidationPairs(const std::vector<PointCloud>& clouds,
                                                    const PairProtocol& protocol, int n,
                                                    std::uint64_t seed);

/// One row of Trainer::overfitOneBatch.
struct OverfitRow {
  int step = 0;
  double loss = 0.0;                ///< training objective (train rows only)
  double rotation_error_deg = 0.0;  ///< mean over the batch, against ground truth
  double translation_error = 0.0;   ///< mean over the batch [cloud units: m for scans]
  std::string mode;                 ///< "train", "eval", or eval with one train-mode part
};

class Trainer {
 public:
  /// Object-level training: pairs made from `train_clouds` / `val_clouds` by the config's
  /// protocols.
  Trainer(TrainConfig config, std::vector<PointCloud> train_clouds,
          std::vector<PointCloud> val_clouds, std::string out_dir);
  /// Any pair source (e.g. KITTI scan pairs): `sampler` draws training pairs, `val_pairs` are
  /// scored after every epoch.
  Trainer(TrainConfig config, PairSampler sampler, std::vector<RegistrationPair> val_pairs,
          std::string out_dir);
  ~Trainer();
  Trainer(const Trainer&) = delete;
  Trainer& operator=(const Trainer&) = delete;

  /// The text run() writes to out_dir/config.yaml: the whole configuration of the run (model,
  /// train and data sections, command-line overrides applied), so that
  /// `obm-train -c OUT/config.yaml -o OUT --resume` continues the same run. When not set, run()
  /// records the model section only (all the library knows).
  void setRunConfigYaml(std::string yaml_text);
  /// Data-parallel training (distributed.hpp): this process is one rank of `group`. Each step's
  /// batch of `batch_size` pairs is split over the ranks (pair j to rank j mod world), the
  /// gradients are averaged by an all-reduce, the validation pairs are shared out and their
  /// scores reduced, and only rank 0 writes files. Call before run(); every rank must run the
  /// same configuration. Throws ConfigError when batch_size < the number of ranks.
  void setProcessGroup(std::shared_ptr<ProcessGroup> group);
  /// Every parameter of the model, flattened in a fixed order (for checks: the copies of a
  /// data-parallel run must stay identical).
  std::vector<float> parameterVector() const;

  /// Runs until `config.epochs` (continuing from out_dir/checkpoint.pt when `resume`), or until
  /// `stop()` returns true (checked between batches; the checkpoint then holds the last whole
  /// epoch). Returns the per-epoch statistics of this run. `on_epoch` is called after each epoch.
  std::vector<EpochStats> run(bool resume, const std::function<bool()>& stop = {},
                              const std::function<void(const EpochStats&)>& on_epoch = {});

  /// Warm start: copies the weights (parameters and batch-norm statistics) of the model file
  /// `model_path` into the model before run(); the optimiser starts fresh. For continuing a run
  /// with another protocol or learning rate (e.g. from best.pt after the curriculum). Settings that
  /// change no layer shape (k1, k2, keypoints, samples, margins, iterations) may differ from the
  /// file's (a warning is logged; the config's are used). Throws ConfigError naming the file and
  /// the layer when a parameter is missing or has another shape (emb_dims, dim, module
  /// switches), IoError / FormatError as loadModel. Ignored by run(resume = true) when a
  /// checkpoint exists (the checkpoint wins).
  void initializeFrom(const std::string& model_path);

  /// Scores the current model on the validation pairs.
  ValidationScores validate();

  /// A sanity check of the learning signal: `steps` optimisation steps on ONE fixed batch of the
  /// training protocol at `epoch`'s curriculum level (a fresh model unless warm-started; nothing
  /// saved). Returns a "train" row every `every` steps (the training objective, pose-label term
  /// included when configured, and the batch's errors in train mode), then three rows of the
  /// trained weights without gradient: "eval" (inference mode), and inference mode with batch
  /// normalisation on the batch's statistics, and with the soft overlap sampling. A model that
  /// cannot fit one batch has a broken gradient path, or a loss whose minimum is not the true pose;
  /// one that fits it in train mode only loses it in what differs between the two modes.
  std::vector<OverfitRow> overfitOneBatch(int steps, int every, int epoch);

  /// Pairs per second of training (forward + backward + step) measured on `n_batches` batches
  /// of the training protocol, without touching the checkpoint. For planning runs.
  double measureThroughput(int n_batches);

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace obmnet
}  // namespace obm
