#include "obm/obmnet/trainer.hpp"

#include <torch/torch.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <iomanip>
#include <optional>
#include <regex>
#include <sstream>

#include "obm/config/config_node.hpp"
#include "obm/core/atomic_file.hpp"
#include "obm/core/errors.hpp"
#include "obm/core/log.hpp"
#include "obm/core/progress.hpp"
#include "obm/core/timer.hpp"
#include "obm/obmnet/collectives.hpp"
#include "obm/obmnet/distributed.hpp"
#include "obm/obmnet/losses.hpp"
#include "obm/obmnet/model.hpp"
#include "obm/obmnet/model_io.hpp"
#include "obm/obmnet/teacher.hpp"
#include "allocator.hpp"

namespace obm::obmnet {

TrainConfig TrainConfig::load(const ConfigNode& root) {
  root.checkKeys({"model", "train", "data"});  // `data:` is read by the tools
  TrainConfig c;
  c.model = ObmNetConfig::load(root.child("model"));
  const ConfigNode t = root.child("train");
  t.checkKeys({"pairs", "val_pairs_protocol", "batch_size", "epochs", "pairs_per_epoch",
               "val_pairs", "lr", "weight_decay", "lr_steps", "lr_gamma", "normalize_radius",
               "recall_deg", "recall_trans", "max_grad_norm", "threads", "seed", "max_hours",
               "save_epochs", "curriculum_epochs", "curriculum_start", "device", "pose_loss_weight",
               "loss_weights", "select_on", "inlier_radius", "match_loss_weight", "teacher"});
  c.protocol = PairProtocol::load(t.child("pairs"));
  c.val_protocol =
      t.has("val_pairs_protocol") ? PairProtocol::load(t.child("val_pairs_protocol")) : c.protocol;
  t.get("batch_size", c.batch_size);
  t.get("epochs", c.epochs);
  t.get("pairs_per_epoch", c.pairs_per_epoch);
  t.get("val_pairs", c.val_pairs);
  t.get("lr", c.lr);
  t.get("weight_decay", c.weight_decay);
  t.get("lr_steps", c.lr_steps);
  t.get("lr_gamma", c.lr_gamma);
  t.get("normalize_radius", c.normalize_radius);
  t.get("recall_deg", c.recall_deg);
  t.get("recall_trans", c.recall_trans);
  t.get("inlier_radius", c.inlier_radius);
  t.get("max_grad_norm", c.max_grad_norm);
  t.get("threads", c.threads);
  t.get("seed", c.seed);
  t.get("max_hours", c.max_hours);
  t.get("save_epochs", c.save_epochs);
  t.get("curriculum_epochs", c.curriculum_epochs);
  t.get("curriculum_start", c.curriculum_start);
  t.get("device", c.device);
  t.get("pose_loss_weight", c.pose_loss_weight);
  t.get("match_loss_weight", c.match_loss_weight);
  if (!(c.match_loss_weight >= 0.0))
    throw ConfigError(t.where("match_loss_weight") + ": must be >= 0");
  if (t.has("teacher")) {
    c.teacher = TeacherParams::load(t.child("teacher"));
  } else if (c.match_loss_weight > 0.0) {
    throw ConfigError(t.where("match_loss_weight") +
                      ": > 0 needs the teacher's settings (a `train.teacher:` map)");
  }
  if (t.has("loss_weights")) {
    std::vector<double> w;
    t.get("loss_weights", w);
    if (w.size() != 3 || !(w[0] >= 0.0 && w[1] >= 0.0 && w[2] >= 0.0) || w[0] + w[1] + w[2] <= 0.0)
      throw ConfigError(t.where("loss_weights") +
                        ": three weights [g, n, s] >= 0, not all 0 (the paper's: [1, 1, 1])");
    c.loss_weights = {w[0], w[1], w[2]};
  }
  if (!(c.pose_loss_weight >= 0.0))
    throw ConfigError(t.where("pose_loss_weight") + ": must be >= 0");
  if (t.has("select_on")) {
    std::string sel;
    t.get("select_on", sel);
    if (sel == "mie_r")
      c.select_on = TrainConfig::Selection::MieR;
    else if (sel == "mie_t")
      c.select_on = TrainConfig::Selection::MieT;
    else
      throw ConfigError(t.where("select_on") + ": '" + sel + "': mie_r or mie_t");
  }
  try {
    const torch::Device dev(c.device);
    if (dev.is_cuda() && !torch::cuda::is_available())
      throw ConfigError(t.where("device") + ": '" + c.device +
                        "' asked for, but this LibTorch build sees no CUDA device "
                        "(torch::cuda::is_available() is false); use cpu");
    if (!dev.is_cpu() && !dev.is_cuda())
      throw ConfigError(t.where("device") + ": '" + c.device + "': cpu or cuda:K");
  } catch (const c10::Error&) {
    throw ConfigError(t.where("device") + ": '" + c.device + "' is not a device (cpu or cuda:K)");
  }
  if (!(c.curriculum_start >= 0.0 && c.curriculum_start < 1.0))
    throw ConfigError(t.where("curriculum_start") + ": must be in [0, 1)");
  auto positive = [&](const char* key, double v) {
    if (!(v > 0)) throw ConfigError(t.where(key) + ": must be > 0");
  };
  positive("batch_size", c.batch_size);
  positive("epochs", c.epochs);
  positive("pairs_per_epoch", c.pairs_per_epoch);
  positive("val_pairs", c.val_pairs);
  positive("lr", c.lr);
  positive("lr_gamma", c.lr_gamma);
  positive("normalize_radius", c.normalize_radius);
  positive("inlier_radius", c.inlier_radius);
  positive("threads", c.threads);
  return c;
}

namespace {

/// Share of the source points whose matched target point (`match`, one target index per source
/// point, in the pair's point order) lies within `radius` of the source point moved by the true
/// pose T_target_source.
/// With `mask` (one int64 per source point), only the points whose mask is >= 0 are scored, and
/// the *count* of inliers among them is returned instead of the share.
double inlierRatio(const RegistrationPair& pair, const torch::Tensor& match, double radius,
                   const torch::Tensor* mask = nullptr) {
  const auto m = match.to(torch::kCPU, torch::kLong).contiguous();
  const auto* idx = m.data_ptr<int64_t>();
  const auto n = static_cast<std::size_t>(m.numel());
  OBM_ASSERT(n == pair.source.size(), "inlierRatio: one match per source point expected");
  torch::Tensor mk;
  if (mask) {
    mk = mask->to(torch::kCPU, torch::kLong).contiguous();
    OBM_ASSERT(static_cast<std::size_t>(mk.numel()) == n, "inlierRatio: one mask entry per point");
  }
  const int64_t* use = mask ? mk.data_ptr<int64_t>() : nullptr;
  std::size_t inliers = 0;
  for (std::size_t i = 0; i < n; ++i) {
    if (use && use[i] < 0) continue;
    const auto q = static_cast<std::size_t>(idx[i]);
    OBM_ASSERT(q < pair.target.size(), "inlierRatio: match index outside the target");
    const Eigen::Vector3d moved = pair.T_target_source * pair.source.points[i].cast<double>();
    if ((moved - pair.target.points[q].cast<double>()).norm() < radius) ++inliers;
  }
  if (mask) return static_cast<double>(inliers);
  return n == 0 ? 0.0 : static_cast<double>(inliers) / static_cast<double>(n);
}

/// A batch of normalised pairs as tensors, and what is needed to score them.
struct Batch {
  torch::Tensor src, tgt;  ///< B×3×N, B×3×M
  std::vector<RegistrationPair> pairs;
  std::vector<PairNormalization> norms;
  /// Pose labels in normalised coordinates (B×3×3, B×3); undefined unless every pair has one.
  torch::Tensor R_label, t_label;
  /// The targets' surface samples (normalised) and normals, B×3×S; undefined unless every pair
  /// has them (RegistrationPair::target_surface). Shorter surfaces are padded by repeating their
  /// first sample, which changes no nearest neighbour.
  torch::Tensor tgt_surface, tgt_normals;
};

torch::Tensor cloudTensor(const PointCloud& c) {
  auto t = torch::empty({3, static_cast<int64_t>(c.size())}, torch::kFloat32);
  auto a = t.accessor<float, 2>();
  for (std::size_t i = 0; i < c.size(); ++i)
    for (int d = 0; d < 3; ++d) a[d][static_cast<int64_t>(i)] = c.points[i][d];
  return t;
}

Batch makeBatch(std::vector<RegistrationPair> pairs, double radius, bool shared_centroid) {
  Batch b;
  std::vector<torch::Tensor> s, t, Rl, tl;
  bool labelled = !pairs.empty();
  for (auto& p : pairs) {
    const auto n = PairNormalization::compute(p.source, p.target, radius, shared_centroid);
    labelled = labelled && p.has_pose_label;
    if (labelled) {
      const RigidTransforms L = fromIsometry(n.normalize(p.T_target_source_label));
      Rl.push_back(L.R[0]);
      tl.push_back(L.t[0]);
    }
    PointCloud src = p.source, tgt = p.target;
    n.applySource(src);
    n.applyTarget(tgt);
    s.push_back(cloudTensor(src));
    t.push_back(cloudTensor(tgt));
    b.norms.push_back(n);
  }
  b.src = torch::stack(s);
  b.tgt = torch::stack(t);
  bool surfaced = !pairs.empty();
  std::size_t S = 0;
  for (const auto& p : pairs) {
    surfaced = surfaced && !p.target_surface.empty() &&
               p.target_normals.size() == p.target_surface.size();
    S = std::max(S, p.target_surface.size());
  }
  if (surfaced) {
    std::vector<torch::Tensor> sf, nf;
    for (std::size_t j = 0; j < pairs.size(); ++j) {
      PointCloud surf = pairs[j].target_surface;
      b.norms[j].applyTarget(surf);  // translation and scale: the normals are unchanged
      PointCloud nrm;
      nrm.points = pairs[j].target_normals;
      surf.points.resize(S, surf.points.front());
      nrm.points.resize(S, nrm.points.front());
      sf.push_back(cloudTensor(surf));
      nf.push_back(cloudTensor(nrm));
    }
    b.tgt_surface = torch::stack(sf);
    b.tgt_normals = torch::stack(nf);
  }
  if (labelled) {
    b.R_label = torch::stack(Rl);
    b.t_label = torch::stack(tl);
  }
  b.pairs = std::move(pairs);
  return b;
}

std::string csvHeader() {
  return "epoch,lr,loss,loss_global,loss_neighbor,loss_spatial,val_loss,val_mie_r_deg,val_mie_t,"
         "val_recall,val_mean_alpha,pairs_per_s,wall_s,best,comm_ms_per_step,loss_pose,"
         "val_inlier_ratio,loss_match,teacher_labelled\n";
}

std::string csvRow(const EpochStats& s) {
  std::ostringstream os;
  os << std::setprecision(8) << s.epoch << ',' << s.lr << ',' << s.loss << ',' << s.loss_global
     << ',' << s.loss_neighbor << ',' << s.loss_spatial << ',' << s.val_loss << ',' << s.val_mie_r
     << ',' << s.val_mie_t << ',' << s.val_recall << ',' << s.val_mean_alpha << ',' << s.pairs_per_s
     << ',' << s.wall_s << ',' << (s.best ? 1 : 0) << ',' << s.comm_ms_per_step << ',' << s.loss_pose << ','
     << s.val_inlier_ratio << ',' << s.loss_match << ',' << s.teacher_labelled << '\n';
  return os.str();
}

}  // namespace

PairProtocol curriculumProtocol(const PairProtocol& target, int epoch, int curriculum_epochs,
                                double curriculum_start) {
  if (curriculum_epochs <= 0 || epoch >= curriculum_epochs) return target;
  const double f0 = std::clamp(curriculum_start, 0.0, 1.0);
  const double f =
      f0 + (1.0 - f0) * std::clamp(static_cast<double>(epoch - 1) / curriculum_epochs, 0.0, 1.0);
  PairProtocol p = target;
  if (target.partial_keep > 0)
    p.partial_keep = static_cast<int>(
        std::lround(target.num_points - f * (target.num_points - target.partial_keep)));
  p.jitter_sigma = f * target.jitter_sigma;
  p.outliers = static_cast<int>(std::lround(f * target.outliers));
  return p;
}

PairSampler objectPairSampler(std::vector<PointCloud> clouds, PairProtocol protocol,
                              int curriculum_epochs, double curriculum_start) {
  if (clouds.empty()) throw ContractError("objectPairSampler: no training clouds");
  auto shared = std::make_shared<const std::vector<PointCloud>>(std::move(clouds));
  return [shared, protocol, curriculum_epochs, curriculum_start](std::mt19937_64& rng,
                                                                 int epoch) {
    std::uniform_int_distribution<std::size_t> pick(0, shared->size() - 1);
    const auto& c = (*shared)[pick(rng)];
    return makePair(c, curriculumProtocol(protocol, epoch, curriculum_epochs, curriculum_start),
                    rng);
  };
}

std::vector<RegistrationPair> objectValidationPairs(const std::vector<PointCloud>& clouds,
                                                    const PairProtocol& protocol, int n,
                                                    std::uint64_t seed) {
  if (clouds.empty()) throw ContractError("objectValidationPairs: no validation clouds");
  std::mt19937_64 rng(seed * 7919u + 17u);
  std::vector<RegistrationPair> pairs;
  for (int i = 0; i < n; ++i)
    pairs.push_back(makePair(clouds[static_cast<std::size_t>(i) % clouds.size()], protocol, rng));
  return pairs;
}

struct Trainer::Impl {
  TrainConfig cfg;
  PairSampler sampler;
  std::string out;
  ObmNet model{nullptr};
  std::unique_ptr<torch::optim::Adam> optim;
  std::vector<RegistrationPair> val_pairs;
  long skipped = 0;  ///< batches skipped for non-finite loss or gradients
  std::string run_config_yaml;  ///< written to out/config.yaml when set
  torch::Device device{torch::kCPU};
  /// Data-parallel run: this process's membership (null = a single process).
  std::shared_ptr<ProcessGroup> group;
  double comm_s = 0.0;  ///< time spent in the per-step collectives (this epoch)

  int rank() const { return group ? group->rank() : 0; }
  int world() const { return group ? group->worldSize() : 1; }
  bool writer() const { return rank() == 0; }  ///< rank 0 writes every file

  Impl(TrainConfig c, PairSampler s, std::vector<RegistrationPair> v, std::string o)
      : cfg(std::move(c)), sampler(std::move(s)), out(std::move(o)), val_pairs(std::move(v)) {
    if (!sampler) throw ContractError("Trainer: no pair sampler");
    if (val_pairs.empty()) throw ContractError("Trainer: no validation pairs");
    torch::manual_seed(cfg.seed);
    ObmNetConfig mc = cfg.model;
    mc.seed = cfg.seed;
    model = ObmNet(mc);
    device = torch::Device(cfg.device);
    model->to(device);
    optim = std::make_unique<torch::optim::Adam>(
        model->parameters(), torch::optim::AdamOptions(cfg.lr).weight_decay(cfg.weight_decay));
  }

  double lrForEpoch(int epoch) const {  // epoch is 1-based
    double lr = cfg.lr;
    for (int s : cfg.lr_steps)
      if (epoch >= s) lr *= cfg.lr_gamma;
    return lr;
  }

  void setLr(double lr) {
    for (auto& g : optim->param_groups())
      static_cast<torch::optim::AdamOptions&>(g.options()).lr(lr);
  }

  std::vector<RegistrationPair> drawPairs(std::mt19937_64& rng, int n, int epoch) const {
    std::vector<RegistrationPair> pairs;
    for (int i = 0; i < n; ++i) pairs.push_back(sampler(rng, epoch));
    return pairs;
  }

  /// The pairs of step `k` of `epoch` that this rank trains on. Pair j of the step's global batch
  /// is drawn from its own generator, seeded by (seed, epoch, k, j): the data of an epoch does not
  /// depend on the number of processes (a run resumes with another world size on the same pairs),
  /// and rank r draws only its shard, the pairs j with j mod world = r.
  /// The seed words of stream `j` of step k of `epoch` (with `salt` for streams other than the
  /// pairs'): every random stream of a step derives from them, never from what ran before.
  std::vector<std::uint32_t> stepSeed(int epoch, int k, int j, std::optional<std::uint32_t> salt = {}) const {
    std::vector<std::uint32_t> w{static_cast<std::uint32_t>(cfg.seed),
                                 static_cast<std::uint32_t>(cfg.seed >> 32),
                                 static_cast<std::uint32_t>(epoch), static_cast<std::uint32_t>(k),
                                 static_cast<std::uint32_t>(j)};
    if (salt) w.push_back(*salt);
    return w;
  }

  std::vector<RegistrationPair> shardOfStep(int epoch, int k) const {
    std::vector<RegistrationPair> pairs;
    for (int j = rank(); j < cfg.batch_size; j += world()) {
      const auto w = stepSeed(epoch, k, j);
      std::seed_seq ss(w.begin(), w.end());
      std::mt19937_64 rng(ss);
      pairs.push_back(sampler(rng, epoch));
    }
    return pairs;
  }

  Batch toDevice(Batch b) const {
    if (!device.is_cpu()) {
      b.src = b.src.to(device);
      b.tgt = b.tgt.to(device);
      if (b.R_label.defined()) {
        b.R_label = b.R_label.to(device);
        b.t_label = b.t_label.to(device);
      }
      if (b.tgt_surface.defined()) {
        b.tgt_surface = b.tgt_surface.to(device);
        b.tgt_normals = b.tgt_normals.to(device);
      }
    }
    return b;
  }

  /// One optimisation step on this rank's shard `b` of a batch of `global_pairs` pairs; returns
  /// the loss terms, averaged over the whole batch.
  /// The Gumbel noise of step k of `epoch` on this rank: its own stream, independent of what ran
  /// before in this process (a resumed run continues bit-identically).
  std::uint64_t noiseSeed(int epoch, int k) const {
    const auto w = stepSeed(epoch, k, rank(), 0x6e6f6973u /* "nois" */);
    std::seed_seq ss(w.begin(), w.end());
    std::uint32_t v[2];
    ss.generate(v, v + 2);
    return (static_cast<std::uint64_t>(v[0]) << 32) | v[1];
  }

  /// L_g + L_n + L_s as train.loss_weights weighs them (o.loss for the paper's weights).
  torch::Tensor objective(const ObmNetOutput& o) const {
    if (cfg.paperLossWeights()) return o.loss;
    const auto& w = cfg.loss_weights;
    return w[0] * o.loss_global + w[1] * o.loss_neighbor + w[2] * o.loss_spatial;
  }

  /// Self-training labels of a batch (teacher.hpp), `labels` B×N: the network's estimate in
  /// inference mode, refined by ICP.
  void teach(const Batch& b, torch::Tensor& labels) {
    torch::NoGradGuard ng;
    model->eval();
    const auto o = model->forward(b.src, b.tgt);
    teacherLabels(b.src, b.tgt, RigidTransforms{o.R, o.t}, cfg.teacher, labels);
  }

  std::array<double, 7> step(const Batch& b, int global_pairs) {
    const int local = static_cast<int>(b.pairs.size());
    // Data-parallel: rank 0's batch-normalisation statistics for every copy (DDP's
    // broadcast_buffers), so that all ranks run the same model.
    if (group) {
      Timer tc;
      std::vector<torch::Tensor> buffers;
      for (const auto& kv : model->named_buffers(true)) buffers.push_back(kv.value());
      broadcastTensors(*group, buffers, 0);
      comm_s += tc.seconds();
    }
    torch::Tensor labels;
    const bool teaching = cfg.match_loss_weight > 0.0;
    if (teaching) teach(b, labels);
    model->train();
    optim->zero_grad();
    const auto o = model->forward(b.src, b.tgt, /*compute_loss=*/true, b.tgt_surface, b.tgt_normals,
                                  labels);
    torch::Tensor total = objective(o), pose = torch::zeros({}, o.loss.options()),
                  match = torch::zeros({}, o.loss.options());
    if (cfg.pose_loss_weight > 0.0) {
      if (!b.R_label.defined())
        throw ConfigError("train.pose_loss_weight > 0, but the training pairs carry no pose label "
                          "(set data.pose_labels to the mapping app's trajectory of each training "
                          "sequence; ground truth is never a label)");
      pose = cfg.pose_loss_weight * poseLabelLoss(o.R, o.t, b.R_label, b.t_label, b.src);
      total = total + pose;
    }
    if (teaching) {
      match = cfg.match_loss_weight * o.loss_match;
      total = total + match;
    }
    const double labelled =
        teaching ? (labels >= 0).to(torch::kFloat64).mean().item<double>() : 0.0;
    std::array<double, 7> l{total.item<double>(),         o.loss_global.item<double>(),
                            o.loss_neighbor.item<double>(), o.loss_spatial.item<double>(),
                            pose.item<double>(),            match.item<double>(),
                            labelled};
    bool finite = std::isfinite(l[0]);
    if (finite) {
      total.backward();
      // A degenerate batch (e.g. repeated singular values in the SVD backward) can produce
      // non-finite gradients; one such batch must not destroy the weights.
      for (const auto& p : model->parameters())
        if (p.grad().defined() && !torch::isfinite(p.grad()).all().item<bool>()) {
          finite = false;
          break;
        }
    }
    // The skip decision and the reported losses are collective: a batch skipped on one rank is
    // skipped on all, or the copies would drift apart.
    std::vector<double> agg{finite ? 0.0 : 1.0, std::isfinite(l[0]) ? 0.0 : 1.0};
    for (double x : l) agg.push_back(std::isfinite(x) ? x * local : 0.0);
    if (group) {
      Timer tc;
      group->allReduceSum(agg);
      comm_s += tc.seconds();
    }
    for (std::size_t i = 0; i < l.size(); ++i) l[i] = agg[2 + i] / global_pairs;
    if (agg[0] > 0) {
      ++skipped;
      OBM_LOG_WARN_THROTTLE("obm-train", 10.0,
                            (agg[1] > 0 ? "non-finite loss" : "non-finite gradient")
                                << "; batch skipped (" << skipped << " so far)");
      optim->zero_grad();
      if (agg[1] > 0) return {0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0};
      return l;
    }
    if (group) {
      Timer tc;
      allReduceGradients(*group, model->parameters(), local, global_pairs);
      comm_s += tc.seconds();
    }
    if (cfg.max_grad_norm > 0)
      torch::nn::utils::clip_grad_norm_(model->parameters(), cfg.max_grad_norm);
    optim->step();
    return l;
  }

  ValidationScores validate() {
    torch::NoGradGuard ng;
    model->eval();
    ValidationScores s;
    int hits = 0;
    int64_t labelled = 0, correct_labels = 0;
    // Data-parallel: each rank scores the pairs i with i mod world = rank; the sums are reduced.
    std::vector<RegistrationPair> mine;
    for (std::size_t i = static_cast<std::size_t>(rank()); i < val_pairs.size();
         i += static_cast<std::size_t>(world()))
      mine.push_back(val_pairs[i]);
    const std::size_t B = static_cast<std::size_t>(cfg.batch_size);
    for (std::size_t i0 = 0; i0 < mine.size(); i0 += B) {
      std::vector<RegistrationPair> chunk(
          mine.begin() + static_cast<std::ptrdiff_t>(i0),
          mine.begin() + static_cast<std::ptrdiff_t>(std::min(mine.size(), i0 + B)));
      const Batch b = toDevice(makeBatch(std::move(chunk), cfg.normalize_radius, cfg.model.shared_centroid));
      const auto o = model->forward(b.src, b.tgt, true, b.tgt_surface, b.tgt_normals);
      s.loss += o.loss.item<double>() * static_cast<double>(b.pairs.size());
      for (std::size_t j = 0; j < b.pairs.size(); ++j) {
        const Isometry3d T = b.norms[j].denormalize(toIsometry(o.R, o.t, static_cast<int64_t>(j)));
        const Isometry3d& G = b.pairs[j].T_target_source;
        const double er = rotationAngle(G.linear().transpose() * T.linear()) * kRadToDeg;
        const double et = (T.translation() - G.translation()).norm();
        s.mie_r += er;
        s.mie_t += et;
        hits += (er < cfg.recall_deg && et < cfg.recall_trans) ? 1 : 0;
        s.mean_alpha += o.alpha[static_cast<int64_t>(j)].item<double>();
        s.inlier_ratio += inlierRatio(b.pairs[j], o.match_index[static_cast<int64_t>(j)].select(1, 0),
                                      cfg.inlier_radius);
      }
      if (cfg.match_loss_weight > 0.0) {
        // What self-training would hand the network on these pairs, scored against ground truth.
        torch::Tensor labels;
        const auto T = teacherLabels(b.src, b.tgt, RigidTransforms{o.R, o.t}, cfg.teacher, labels);
        for (std::size_t j = 0; j < b.pairs.size(); ++j) {
          const auto lj = labels[static_cast<int64_t>(j)];
          const auto n = (lj >= 0).sum().item<int64_t>();
          labelled += n;
          // inlierRatio over every point counts the labelled ones that are right (−1 never is,
          // once mapped to an index whose distance is then ignored).
          const auto right = inlierRatio(b.pairs[j], lj.clamp_min(0), cfg.inlier_radius,
                                         /*mask=*/&lj);
          correct_labels += static_cast<int64_t>(std::lround(right));
          const Isometry3d Tt = b.norms[j].denormalize(toIsometry(T.R, T.t, static_cast<int64_t>(j)));
          s.teacher_mie_r +=
              rotationAngle(b.pairs[j].T_target_source.linear().transpose() * Tt.linear()) * kRadToDeg;
        }
      }
    }
    if (group) {
      std::vector<double> sums{s.loss,       s.mie_r, s.mie_t, s.mean_alpha, static_cast<double>(hits),
                               s.inlier_ratio, static_cast<double>(labelled),
                               static_cast<double>(correct_labels), s.teacher_mie_r};
      group->allReduceSum(sums);
      s.inlier_ratio = sums[5];
      labelled = static_cast<int64_t>(std::llround(sums[6]));
      correct_labels = static_cast<int64_t>(std::llround(sums[7]));
      s.teacher_mie_r = sums[8];
      s.loss = sums[0];
      s.mie_r = sums[1];
      s.mie_t = sums[2];
      s.mean_alpha = sums[3];
      hits = static_cast<int>(std::lround(sums[4]));
    }
    const double n = static_cast<double>(val_pairs.size());
    s.loss /= n;
    s.mie_r /= n;
    s.mie_t /= n;
    s.mean_alpha /= n;
    s.inlier_ratio /= n;
    s.recall = hits / n;
    if (cfg.match_loss_weight > 0.0) {
      std::size_t points = 0;
      for (const auto& p : val_pairs) points += p.source.size();
      s.teacher_labelled = points ? static_cast<double>(labelled) / static_cast<double>(points) : 0.0;
      s.teacher_precision =
          labelled ? static_cast<double>(correct_labels) / static_cast<double>(labelled) : 0.0;
      s.teacher_mie_r /= n;
    }
    return s;
  }

  // ---- checkpoint: model + optimiser + progress ----
  std::string ckptPath() const { return out + "/checkpoint.pt"; }

  void saveCheckpoint(int epoch, double best, double wall_s) {
    torch::serialize::OutputArchive a;
    torch::serialize::OutputArchive m, o;
    model->save(m);
    optim->save(o);
    a.write("model", m);
    a.write("optimizer", o);
    a.write("epoch", c10::IValue(static_cast<int64_t>(epoch)));
    a.write("best_val_mie_r", c10::IValue(best));
    a.write("wall_s", c10::IValue(wall_s));
    saveArchiveAtomically(a, ckptPath(), "the checkpoint");
  }

  /// Returns (epoch done, best, wall) or epoch 0 when there is no checkpoint.
  std::tuple<int, double, double> loadCheckpoint() {
    if (!std::filesystem::exists(ckptPath())) return {0, 1e300, 0.0};
    torch::serialize::InputArchive a, m, o;
    try {
      a.load_from(ckptPath());
      a.read("model", m);
      a.read("optimizer", o);
      model->load(m);
      optim->load(o);
    } catch (const c10::Error& e) {
      throw FormatError(
          ckptPath(), 0,
          std::string("cannot resume from this checkpoint (") + e.what_without_backtrace() + ")");
    }
    c10::IValue v;
    a.read("epoch", v);
    const int epoch = static_cast<int>(v.toInt());
    a.read("best_val_mie_r", v);
    const double best = v.toDouble();
    a.read("wall_s", v);
    return {epoch, best, v.toDouble()};
  }
};

Trainer::Trainer(TrainConfig config, std::vector<PointCloud> train_clouds,
                 std::vector<PointCloud> val_clouds, std::string out_dir) {
  detail::keepFreedTensorMemory();
  auto val = objectValidationPairs(val_clouds, config.val_protocol, config.val_pairs, config.seed);
  auto sampler =
      objectPairSampler(std::move(train_clouds), config.protocol, config.curriculum_epochs,
                        config.curriculum_start);
  impl_ = std::make_unique<Impl>(std::move(config), std::move(sampler), std::move(val),
                                 std::move(out_dir));
}

Trainer::Trainer(TrainConfig config, PairSampler sampler, std::vector<RegistrationPair> val_pairs,
                 std::string out_dir) {
  detail::keepFreedTensorMemory();
  impl_ = std::make_unique<Impl>(std::move(config), std::move(sampler), std::move(val_pairs),
                                 std::move(out_dir));
}

Trainer::~Trainer() = default;

ValidationScores Trainer::validate() {
  return impl_->validate();
}

void Trainer::initializeFrom(const std::string& model_path) {
  ObmNet src = loadModel(model_path);
  Impl& I = *impl_;
  // Every parameter and buffer must exist with the same shape. Settings that change no shape
  // (k1, k2, keypoints, samples, margins, iterations) may differ: the weights are per edge /
  // per point, e.g. a model trained with k1 = 5 can be warm-started with k1 = 16 for noisy data.
  const auto from_p = src->named_parameters(true);
  const auto from_b = src->named_buffers(true);
  // The one shape change allowed: a model without edge normals warm-starts one with them. The
  // EdgeConv layers' inputs then begin with the six normal channels ([n_i, n_j − n_i, x_j − x_i,
  // h…]); their weights start at zero, so the warm-started network computes what the old one did.
  const bool adds_normals = I.model->config().edge_normals && !src->config().edge_normals;
  const int64_t extra_edge_channels = adds_normals ? 6 : 0;
  auto widened = [&](const std::string& key, const torch::Tensor& to, const torch::Tensor& f) {
    static const std::regex layer_weight(R"(extractor\.layer[1-4]\.0\.weight)");
    return extra_edge_channels > 0 && std::regex_match(key, layer_weight) && to.dim() == 4 &&
           f.dim() == 4 && to.size(0) == f.size(0) &&
           to.size(1) == f.size(1) + extra_edge_channels;
  };
  auto check = [&](const std::string& key, const torch::Tensor& to,
                   const torch::OrderedDict<std::string, torch::Tensor>& from) {
    const torch::Tensor* f = from.find(key);
    if (f != nullptr && widened(key, to, *f)) return;
    if (f == nullptr || f->sizes() != to.sizes())
      throw ConfigError(model_path + ": '" + key +
                        "' is missing or has another shape than in the training config's "
                        "`model:` (a warm start needs the same layer sizes: emb_dims, dim, the "
                        "module switches)");
  };
  for (const auto& kv : I.model->named_parameters(true)) check(kv.key(), kv.value(), from_p);
  for (const auto& kv : I.model->named_buffers(true)) check(kv.key(), kv.value(), from_b);
  if (src->config().toYaml() != I.model->config().toYaml())
    OBM_LOG_WARN("obm-train", model_path << ": model settings differ from the training config's "
                                             "(compatible layer sizes); the config's are used");
  torch::NoGradGuard ng;
  for (auto& kv : I.model->named_parameters(true)) {
    const auto& f = from_p[kv.key()];
    if (widened(kv.key(), kv.value(), f)) {
      kv.value().zero_();
      kv.value().narrow(1, extra_edge_channels, f.size(1)).copy_(f);
    } else {
      kv.value().copy_(f);
    }
  }
  for (auto& kv : I.model->named_buffers(true)) kv.value().copy_(from_b[kv.key()]);
  OBM_LOG_INFO("obm-train", "weights initialised from " << model_path);
}

std::vector<OverfitRow> Trainer::overfitOneBatch(int steps, int every, int epoch) {
  Impl& I = *impl_;
  std::mt19937_64 rng(I.cfg.seed + 4242u);
  const Batch b =
      I.toDevice(makeBatch(I.drawPairs(rng, I.cfg.batch_size, epoch), I.cfg.normalize_radius, I.cfg.model.shared_centroid));
  // Mean rotation [deg] and translation [cloud units] error of the batch against ground truth.
  auto row = [&](int step, double loss, const ObmNetOutput& o, const char* mode) {
    OverfitRow r{step, loss, 0.0, 0.0, mode};
    for (std::size_t j = 0; j < b.pairs.size(); ++j) {
      const Isometry3d T = b.norms[j].denormalize(toIsometry(o.R, o.t, static_cast<int64_t>(j)));
      const Isometry3d& G = b.pairs[j].T_target_source;
      r.rotation_error_deg += rotationAngle(G.linear().transpose() * T.linear()) * kRadToDeg;
      r.translation_error += (G.translation() - T.translation()).norm();
    }
    r.rotation_error_deg /= static_cast<double>(b.pairs.size());
    r.translation_error /= static_cast<double>(b.pairs.size());
    return r;
  };
  std::vector<OverfitRow> rows;
  for (int s = 0; s < steps; ++s) {
    // Self-training relabels the batch with the current weights before every step, as step() does.
    torch::Tensor labels;
    const bool teaching = I.cfg.match_loss_weight > 0.0;
    if (teaching) I.teach(b, labels);
    I.model->train();
    I.optim->zero_grad();
    const auto o = I.model->forward(b.src, b.tgt, true, b.tgt_surface, b.tgt_normals, labels);
    // The training objective, pose-label and correspondence terms included (as in step()).
    torch::Tensor total = I.objective(o);
    if (I.cfg.pose_loss_weight > 0.0 && b.R_label.defined())
      total = total + I.cfg.pose_loss_weight * poseLabelLoss(o.R, o.t, b.R_label, b.t_label, b.src);
    if (teaching) total = total + I.cfg.match_loss_weight * o.loss_match;
    if (s % every == 0 || s + 1 == steps) rows.push_back(row(s, total.item<double>(), o, "train"));
    total.backward();
    I.optim->step();
  }
  torch::NoGradGuard ng;
  // The trained weights in the inference mode, then with one of its two differences from the
  // training mode undone at a time: batch normalisation on the batch's own statistics instead of
  // the running ones, and the soft (relaxed) overlap sampling instead of the one-hot draw. A gap
  // between the train rows and "eval" that one of them closes is that difference's.
  const auto batchNormTrain = [&](bool on) {
    for (const auto& m : I.model->modules(/*include_self=*/false)) {
      const bool bn = dynamic_cast<torch::nn::BatchNorm1dImpl*>(m.get()) != nullptr ||
                      dynamic_cast<torch::nn::BatchNorm2dImpl*>(m.get()) != nullptr;
      if (bn) m->train(on);
    }
  };
  // Running statistics would be updated by a batch-statistics pass: keep them.
  std::vector<torch::Tensor> saved;
  for (const auto& kv : I.model->named_buffers(true)) saved.push_back(kv.value().clone());
  I.model->eval();
  rows.push_back(row(steps, 0.0, I.model->forward(b.src, b.tgt, false), "eval"));
  batchNormTrain(true);
  rows.push_back(row(steps, 0.0, I.model->forward(b.src, b.tgt, false), "eval, batch-norm on batch statistics"));
  batchNormTrain(false);
  {
    std::size_t i = 0;
    for (auto& kv : I.model->named_buffers(true)) kv.value().copy_(saved[i++]);
  }
  const bool soft = I.model->config().soft_inference_sampling;
  I.model->setSoftInferenceSampling(true);
  rows.push_back(row(steps, 0.0, I.model->forward(b.src, b.tgt, false), "eval, soft overlap sampling"));
  I.model->setSoftInferenceSampling(soft);
  return rows;
}

void Trainer::setRunConfigYaml(std::string yaml_text) {
  impl_->run_config_yaml = std::move(yaml_text);
}

double Trainer::measureThroughput(int n_batches) {
  Impl& I = *impl_;
  // The batches of the last epoch (this rank's shard of each); one warm-up batch (allocations),
  // then timed ones. Pairs per second of the whole run (all ranks).
  auto batch = [&](int k) {
    return I.toDevice(makeBatch(I.shardOfStep(I.cfg.epochs, k), I.cfg.normalize_radius, I.cfg.model.shared_centroid));
  };
  I.step(batch(0), I.cfg.batch_size);
  Timer t;
  for (int k = 1; k <= n_batches; ++k) I.step(batch(k), I.cfg.batch_size);
  return n_batches * I.cfg.batch_size / t.seconds();
}

void Trainer::setProcessGroup(std::shared_ptr<ProcessGroup> group) {
  if (group && group->worldSize() > impl_->cfg.batch_size)
    throw ConfigError("train.batch_size = " + std::to_string(impl_->cfg.batch_size) +
                      " is smaller than the number of processes (" +
                      std::to_string(group->worldSize()) + "): every rank needs a pair per step");
  // The collectives run on CPU tensors (Gloo). A CUDA run across processes needs NCCL's process
  // group, which this build does not have: said plainly rather than copying every step to the
  // host.
  if (group && group->worldSize() > 1 && !impl_->device.is_cpu())
    throw ConfigError("train.device = " + impl_->cfg.device +
                      ": data-parallel training is implemented for cpu (Gloo) only; NCCL for CUDA "
                      "devices is not built in");
  impl_->group = std::move(group);
}

std::vector<float> Trainer::parameterVector() const {
  torch::NoGradGuard ng;
  std::vector<torch::Tensor> parts;
  for (const auto& p : impl_->model->parameters())
    parts.push_back(p.detach().to(torch::kCPU, torch::kFloat32).flatten());
  const auto flat = torch::cat(parts).contiguous();
  return std::vector<float>(flat.data_ptr<float>(), flat.data_ptr<float>() + flat.numel());
}

std::vector<EpochStats> Trainer::run(bool resume, const std::function<bool()>& stop,
                                     const std::function<void(const EpochStats&)>& on_epoch) {
  Impl& I = *impl_;
  // Data-parallel: rank 0 writes every file; the others only train and validate their shards.
  const bool writer = I.writer();
  if (writer) ensureDirectory(I.out);
  if (writer)
    writeTextAtomically(I.out + "/config.yaml",
                      !I.run_config_yaml.empty()
                          ? I.run_config_yaml
                          : "# model configuration of this run\nmodel:\n" + [&] {
                              std::string y = I.cfg.model.toYaml(), r;
                              std::istringstream is(y);
                              for (std::string line; std::getline(is, line);)
                                r += "  " + line + "\n";
                              return r;
                            }());
  int start_epoch = 0;
  double best = 1e300, wall0 = 0.0;
  if (resume) {
    std::tie(start_epoch, best, wall0) = I.loadCheckpoint();
    if (I.group) {  // every rank must resume from the same epoch (a shared output folder)
      std::vector<double> e{static_cast<double>(start_epoch), 1.0};
      I.group->allReduceSum(e);
      if (std::lround(e[0]) != static_cast<long>(start_epoch) * I.world())
        throw IoError(I.ckptPath() + ": rank " + std::to_string(I.rank()) + " resumes after epoch " +
                      std::to_string(start_epoch) +
                      " but the ranks disagree: every process must see the same output folder");
    }
    if (start_epoch > 0 && writer)
      OBM_LOG_INFO("obm-train", "resuming after epoch " << start_epoch << " (best validation score "
                                                        << best
                                                        << (I.cfg.select_on == TrainConfig::Selection::MieT
                                                                ? " m, "
                                                                : " deg, ")
                                                        << wall0
                                                        << " s trained)");
  }
  const std::string csv = I.out + "/train_log.csv";
  std::string csv_text;
  if (!writer) {
    // Only rank 0 keeps the log.
  } else if (start_epoch > 0 && std::filesystem::exists(csv)) {
    // Keep the rows of the epochs the checkpoint holds (later rows belong to an interrupted run).
    std::ifstream in(csv);
    std::string line;
    std::getline(in, line);
    csv_text = csvHeader();
    while (std::getline(in, line)) {
      if (line.empty()) continue;
      if (std::stoi(line.substr(0, line.find(','))) > start_epoch) continue;
      // Rows of an older version lack the last columns: left empty.
      const auto columns = [](const std::string& l) { return std::count(l.begin(), l.end(), ','); };
      const auto missing = columns(csvHeader()) - columns(line);
      csv_text += line + std::string(static_cast<std::size_t>(std::max<long>(0, missing)), ',') + "\n";
    }
  } else {
    csv_text = csvHeader();
  }
  if (writer) writeTextAtomically(csv, csv_text);
  // Every copy starts from rank 0's weights (a warm start or a fresh initialisation drawn in
  // each process would otherwise differ).
  if (I.group) {
    std::vector<torch::Tensor> all;
    for (const auto& p : I.model->parameters()) all.push_back(p);
    for (const auto& kv : I.model->named_buffers(true)) all.push_back(kv.value());
    broadcastTensors(*I.group, all, 0);
  }

  std::vector<EpochStats> stats;
  const int steps = (I.cfg.pairs_per_epoch + I.cfg.batch_size - 1) / I.cfg.batch_size;
  Timer wall;
  for (int epoch = start_epoch + 1; epoch <= I.cfg.epochs; ++epoch) {
    std::vector<double> out_of_time{
        writer && I.cfg.max_hours > 0 && wall0 + wall.seconds() > I.cfg.max_hours * 3600.0 ? 1.0
                                                                                            : 0.0};
    if (I.group) I.group->allReduceSum(out_of_time);  // rank 0's clock decides for all
    if (out_of_time[0] > 0) {
      OBM_LOG_WARN("obm-train", "max_hours reached; stopping before epoch " << epoch);
      break;
    }
    EpochStats s;
    s.epoch = epoch;
    s.lr = I.lrForEpoch(epoch);
    I.setLr(s.lr);
    // Pairs of epoch e depend only on (seed, e) (shardOfStep): a resumed run sees the same data.
    ProgressBar bar(static_cast<std::size_t>(steps),
                    "epoch " + std::to_string(epoch) + "/" + std::to_string(I.cfg.epochs),
                    "batches");
    bar.setEnabled(writer);
    Timer et;
    I.comm_s = 0.0;
    bool interrupted = false;
    for (int k = 0; k < steps; ++k) {
      // A stop on any rank (Ctrl-C reaches every process of a launch) stops all at this step.
      std::vector<double> stopping{stop && stop() ? 1.0 : 0.0};
      if (I.group) I.group->allReduceSum(stopping);
      if (stopping[0] > 0) {
        interrupted = true;
        break;
      }
      I.model->seedTrainingNoise(I.noiseSeed(epoch, k));
      const auto l = I.step(I.toDevice(makeBatch(I.shardOfStep(epoch, k), I.cfg.normalize_radius, I.cfg.model.shared_centroid)),
                            I.cfg.batch_size);
      s.loss += l[0];
      s.loss_global += l[1];
      s.loss_neighbor += l[2];
      s.loss_spatial += l[3];
      s.loss_pose += l[4];
      s.loss_match += l[5];
      s.teacher_labelled += l[6];
      std::ostringstream st;
      st << std::setprecision(4) << "loss " << s.loss / (k + 1) << "  " << std::setprecision(3)
         << (k + 1) * I.cfg.batch_size / et.seconds() << " pairs/s";
      bar.update(static_cast<std::size_t>(k + 1), st.str());
    }
    if (interrupted) {
      bar.finish("interrupted");
      OBM_LOG_WARN("obm-train", "interrupted: epoch "
                                    << epoch << " discarded, checkpoint holds epoch " << epoch - 1);
      break;
    }
    const double train_s = et.seconds();
    s.pairs_per_s = steps * I.cfg.batch_size / train_s;
    s.comm_ms_per_step = 1000.0 * I.comm_s / steps;
    s.loss /= steps;
    s.loss_global /= steps;
    s.loss_neighbor /= steps;
    s.loss_spatial /= steps;
    s.loss_pose /= steps;
    s.loss_match /= steps;
    s.teacher_labelled /= steps;
    const auto v = I.validate();
    s.val_loss = v.loss;
    s.val_mie_r = v.mie_r;
    s.val_mie_t = v.mie_t;
    s.val_recall = v.recall;
    s.val_mean_alpha = v.mean_alpha;
    s.val_inlier_ratio = v.inlier_ratio;
    s.wall_s = wall0 + wall.seconds();
    const double score = I.cfg.select_on == TrainConfig::Selection::MieT ? v.mie_t : v.mie_r;
    if (score < best) {
      best = score;
      s.best = true;
    }
    if ((s.best || I.cfg.save_epochs) && writer) {
      ModelMeta meta;
      meta.normalize_radius = I.cfg.normalize_radius;
      // The points per cloud *before* a partial crop: inference samples clouds larger than this
      // down to it and keeps smaller ones whole. Recording the cropped count instead would make
      // inference sub-sample the source and the target of a full (clean) pair independently, so
      // identical clouds would no longer share their points.
      meta.num_points = I.cfg.protocol.num_points;
      meta.description =
          "epoch " + std::to_string(epoch) + ", val MIE(R) " + std::to_string(v.mie_r) +
          " deg, MIE(t) " + std::to_string(v.mie_t);
      if (s.best) saveModel(I.out + "/best.pt", I.model, meta);
      if (I.cfg.save_epochs) {
        std::ostringstream name;
        name << I.out << "/epoch_" << std::setw(3) << std::setfill('0') << epoch << ".pt";
        saveModel(name.str(), I.model, meta);
      }
    }
    std::ostringstream st;
    st << std::setprecision(4) << "loss " << s.loss << "  val MIE(R) " << v.mie_r << " deg  recall "
       << v.recall << "  inliers " << v.inlier_ratio << (s.best ? "  *best*" : "");
    bar.finish(st.str());
    if (writer) {
      I.saveCheckpoint(epoch, best, s.wall_s);
      csv_text += csvRow(s);
      writeTextAtomically(csv, csv_text);
    }
    // The other ranks go on only once the checkpoint of this epoch exists.
    if (I.group) I.group->barrier();
    stats.push_back(s);
    if (on_epoch) on_epoch(s);
  }
  return stats;
}

}  // namespace obm::obmnet
