#include "obm/obmnet/registrar.hpp"

#include <torch/torch.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <mutex>

#include "obm/core/cloud_ops.hpp"
#include "obm/core/errors.hpp"
#include "obm/core/ransac_pose.hpp"
#include "obm/core/timer.hpp"
#include "obm/obmnet/data.hpp"
#include "obm/obmnet/model_io.hpp"
#include "obm/obmnet/teacher.hpp"
#include "allocator.hpp"

namespace obm::obmnet {

struct ObmNetRegistrar::Impl {
  Options opt;
  obmnet::ModelMeta meta;
  ObmNet model{nullptr};
  mutable std::mutex mutex;  // the module is not re-entrant (eval generator, buffers)
};

ObmNetRegistrar::ObmNetRegistrar(const Options& options) : impl_(std::make_unique<Impl>()) {
  detail::keepFreedTensorMemory();
  impl_->opt = options;
  impl_->model = obmnet::loadModel(options.model_path, &impl_->meta);
  if (impl_->opt.num_points <= 0) impl_->opt.num_points = impl_->meta.num_points;
  if (options.soft_sampling >= 0) impl_->model->setSoftInferenceSampling(options.soft_sampling > 0);
  if (options.iterations < 0)
    throw ContractError("ObmNetRegistrar: iterations must be >= 0 (0 = the model's)");
  if (options.iterations > 0) impl_->model->setIterations(options.iterations);
  if (options.spatial_sigma < 0.0 && options.spatial_sigma != -1.0)
    throw ContractError("ObmNetRegistrar: spatial_sigma must be >= 0, or -1 for the model's");
  if (options.spatial_sigma >= 0.0) impl_->model->setSpatialPrior(options.spatial_sigma);
  if (options.ransac_iterations < 0 || options.ransac_candidates < 1 ||
      options.ransac_candidates > kMatchCandidates || !(options.ransac_inlier_spacing > 0.0) ||
      !(options.ransac_max_turn_deg > 0.0 && options.ransac_max_turn_deg <= 180.0))
    throw ContractError(
        "ObmNetRegistrar: ransac_iterations must be >= 0, ransac_candidates in [1, " +
        std::to_string(kMatchCandidates) +
        "], ransac_inlier_spacing > 0 and ransac_max_turn_deg in (0, 180]");
  if (!(options.min_consensus >= 0.0 && options.min_consensus <= 1.0))
    throw ContractError("ObmNetRegistrar: min_consensus must be in [0, 1] (0 = off)");
  if (!(options.start_heading_margin >= 1.0))
    throw ContractError("ObmNetRegistrar: start_heading_margin must be >= 1 (1 = no preference)");
  if (options.threads > 0) torch::set_num_threads(options.threads);
}

ObmNetRegistrar::~ObmNetRegistrar() = default;
ObmNetRegistrar::ObmNetRegistrar(ObmNetRegistrar&&) noexcept = default;
ObmNetRegistrar& ObmNetRegistrar::operator=(ObmNetRegistrar&&) noexcept = default;

int ObmNetRegistrar::numPoints() const {
  return impl_->opt.num_points;
}

std::string ObmNetRegistrar::describe() const {
  return impl_->opt.model_path + " (" + impl_->meta.description + ")\n" +
         impl_->model->config().toYaml();
}

namespace {
/// The network's float rotation made exactly orthonormal.
Isometry3d orthonormalized(const Isometry3d& T) {
  return makeIsometry(orthonormalize(T.linear()), T.translation());
}

torch::Tensor toTensor(const PointCloud& c) {
  auto t = torch::empty({1, 3, static_cast<int64_t>(c.size())}, torch::kFloat32);
  auto a = t.accessor<float, 3>();
  for (std::size_t i = 0; i < c.size(); ++i)
    for (int d = 0; d < 3; ++d) a[0][d][static_cast<int64_t>(i)] = c.points[i][d];
  return t;
}
}  // namespace

RegistrationResult ObmNetRegistrar::align(const PointCloud& source,
                                          const PointCloud& target) const {
  Timer timer;
  const auto& cfg = impl_->model->config();
  const std::size_t need = static_cast<std::size_t>(std::max(cfg.k1, cfg.k2));
  if (source.size() < need || target.size() < need)
    throw ContractError("ObmNetRegistrar::align: clouds need at least " + std::to_string(need) +
                        " points (source has " + std::to_string(source.size()) + ", target " +
                        std::to_string(target.size()) + ")");
  RegistrationResult r;
  std::mt19937_64 rng(impl_->opt.seed);
  const auto n = static_cast<std::size_t>(impl_->opt.num_points);
  // The model was trained on sweeps without their road (ObmNetConfig::ground_band): cut it the
  // same way, keeping the map from the kept points back to the input indices.
  std::vector<std::size_t> source_kept;
  PointCloud source_cut, target_cut;
  const bool cut = cfg.ground_band > 0.0;
  if (cut) {
    source_cut = removeGround(source, cfg.ground_band, 1, &source_kept);
    target_cut = removeGround(target, cfg.ground_band, 2);
    if (source_cut.size() < need || target_cut.size() < need)
      throw ContractError("ObmNetRegistrar::align: fewer than " + std::to_string(need) +
                          " points above the ground plane (source " +
                          std::to_string(source_cut.size()) + ", target " +
                          std::to_string(target_cut.size()) + ")");
  }
  const PointCloud& source_in = cut ? source_cut : source;
  const PointCloud& target_in = cut ? target_cut : target;
  if (cfg.voxel_keypoints) {
    // The model was trained on voxel keypoints (scans): sample as in training.
    r.source_sampled = obmnet::voxelKeypoints(source_in, n, rng, &r.source_indices);
    r.target_sampled = obmnet::voxelKeypoints(target_in, n, rng);
  } else {
    r.source_sampled = randomSubset(source_in, n, rng, &r.source_indices);
    r.target_sampled = randomSubset(target_in, n, rng);
  }
  if (cut)
    for (auto& i : r.source_indices) i = source_kept[i];
  const auto norm = obmnet::PairNormalization::compute(r.source_sampled, r.target_sampled,
                                                       impl_->meta.normalize_radius,
                                                       cfg.shared_centroid);
  PointCloud src = obmnet::neighbourMean(r.source_sampled, impl_->opt.denoise_neighbors);
  PointCloud tgt = obmnet::neighbourMean(r.target_sampled, impl_->opt.denoise_neighbors);
  norm.applySource(src);
  norm.applyTarget(tgt);
  int H = impl_->opt.yaw_hypotheses > 0 ? impl_->opt.yaw_hypotheses : (cfg.planar ? 4 : 1);
  H = std::max(1, H);
  // The hypotheses: the normalised source turned about z by 360°·h/H, in one batch; pose h is
  // then T̂_h · Rz_h. The pivot is the normalised origin (the source's centroid), except for
  // models normalised about a shared centre (sensor-frame scans), which turn it about its
  // sensor, as their training does (scan_source's label_yaw_hypotheses): the sensor sits at
  // s·(0 − c) in normalised coordinates.
  const Eigen::Vector3d pivot = cfg.shared_centroid
                                    ? Eigen::Vector3d(-norm.scale * norm.centroid_source)
                                    : Eigen::Vector3d::Zero();
  auto turn = [&](const Eigen::Matrix3d& R) {  // about the pivot: p ↦ R (p − o) + o
    return makeIsometry(R, pivot - R * pivot);
  };
  std::vector<Eigen::Matrix3d> Rz(static_cast<std::size_t>(H));
  torch::Tensor src_t = toTensor(src), tgt_t = toTensor(tgt);
  if (H > 1) {
    std::vector<torch::Tensor> rows;
    for (int h = 0; h < H; ++h) {
      Rz[static_cast<std::size_t>(h)] =
          Eigen::AngleAxisd(2.0 * 3.14159265358979323846 * h / H, Eigen::Vector3d::UnitZ())
              .toRotationMatrix();
      rows.push_back(toTensor(src.transformed(turn(Rz[static_cast<std::size_t>(h)]), src.frame_id)));
    }
    src_t = torch::cat(rows, 0);
    tgt_t = tgt_t.repeat({H, 1, 1});
  } else {
    Rz[0] = Eigen::Matrix3d::Identity();
  }
  ObmNetOutput o;
  {
    std::lock_guard<std::mutex> lock(impl_->mutex);
    torch::NoGradGuard ng;
    o = impl_->model->forward(src_t, tgt_t, false);
  }
  // Fitness of each hypothesis on the normalised keypoints: the share of source points with a
  // target point within twice the target's median spacing (brute force: ≤ 2048² distances).
  const std::size_t M = tgt.size();
  std::vector<float> spacing(M, std::numeric_limits<float>::max());
  for (std::size_t a = 0; a < M; ++a)
    for (std::size_t b = 0; b < M; ++b)
      if (a != b) spacing[a] = std::min(spacing[a], (tgt.points[a] - tgt.points[b]).squaredNorm());
  std::nth_element(spacing.begin(), spacing.begin() + static_cast<std::ptrdiff_t>(M / 2),
                   spacing.end());
  const float gate2 = 4.0f * spacing[M / 2];
  auto fitness = [&](const Isometry3d& T) {
    const Eigen::Matrix3f Rf = T.linear().cast<float>();
    const Eigen::Vector3f tf = T.translation().cast<float>();
    std::size_t in = 0;
    for (const auto& p : src.points) {
      const Eigen::Vector3f q = Rf * p + tf;
      for (const auto& y : tgt.points)
        if ((q - y).squaredNorm() <= gate2) {
          ++in;
          break;
        }
    }
    return static_cast<double>(in) / static_cast<double>(std::max<std::size_t>(1, src.size()));
  };
  // Which score chooses among the hypotheses: the fitness of their poses, or (select_by_consensus)
  // the share of source points in RANSAC's consensus on the network's own matches. The two differ
  // where a wrong pose lies on repeated structure (a street turned round): its points still land
  // near target points, but the network's matches do not agree on it.
  const bool by_consensus = impl_->opt.select_by_consensus && impl_->opt.ransac_iterations > 0;
  int best = 0;
  double best_score = -1.0;
  std::vector<Isometry3d> T_hat(static_cast<std::size_t>(H));
  std::vector<double> fit_of(static_cast<std::size_t>(H), 0.0);
  std::vector<double> consensus_of(static_cast<std::size_t>(H), -1.0);
  std::vector<double> score_of(static_cast<std::size_t>(H), 0.0);
  for (int h = 0; h < H; ++h) {
    T_hat[static_cast<std::size_t>(h)] = orthonormalized(toIsometry(o.R, o.t, h)) *
                                         turn(Rz[static_cast<std::size_t>(h)]);
    bool have_consensus_pose = false;
    Isometry3d T_r = Isometry3d::Identity();
    if (impl_->opt.ransac_iterations > 0) {
      // The network's putative pairs for this hypothesis: each (turned) source point and its most
      // probable target points; a consensus pose from them competes with the weighted SVD's.
      const Isometry3d T_turn = turn(Rz[static_cast<std::size_t>(h)]);
      const auto idx = o.match_index[h].contiguous();
      const auto prob = o.match_prob[h].to(torch::kFloat64).contiguous();
      const auto* ip = idx.data_ptr<int64_t>();
      const auto* pp = prob.data_ptr<double>();
      const auto C = static_cast<std::size_t>(idx.size(1));
      const std::size_t use = std::min<std::size_t>(
          C, static_cast<std::size_t>(std::max(1, impl_->opt.ransac_candidates)));
      std::vector<Eigen::Vector3d> ps, qs;
      std::vector<double> ws;
      RansacPoseParams rp;
      for (std::size_t i = 0; i < src.size(); ++i) {
        const Eigen::Vector3d p = T_turn * src.points[i].cast<double>();
        for (std::size_t c = 0; c < use; ++c) {
          ps.push_back(p);
          qs.push_back(tgt.points[static_cast<std::size_t>(ip[i * C + c])].cast<double>());
          ws.push_back(pp[i * C + c]);
          rp.group.push_back(i);
        }
      }
      rp.planar = cfg.planar;
      rp.iterations = impl_->opt.ransac_iterations;
      // The pass covers the headings around its hypothesis (training turned sources by up to
      // ±45°); a consensus beyond them belongs to another hypothesis's search.
      rp.max_yaw = impl_->opt.ransac_max_turn_deg * 3.14159265358979323846 / 180.0;
      rp.inlier_threshold =
          impl_->opt.ransac_inlier_spacing * std::sqrt(static_cast<double>(spacing[M / 2]));
      rp.seed = impl_->opt.seed + static_cast<std::uint64_t>(h) + 1;
      const RansacPoseResult rr = ransacPose(ps, qs, rp, ws);
      consensus_of[static_cast<std::size_t>(h)] =
          rr.ok ? static_cast<double>(rr.inliers) /
                      static_cast<double>(std::max<std::size_t>(1, src.size()))
                : 0.0;
      have_consensus_pose = rr.ok;
      if (rr.ok) T_r = rr.T_target_source * T_turn;
    }
    // Ranked by consensus, the consensus pose stands for its hypothesis whenever RANSAC found one
    // (the weighted SVD's pose is then not scored at all); ranked by fitness, it replaces the
    // weighted SVD's pose only when fitter. The fitness, within one spacing of a true pose, cannot
    // tell a pose 0.3 m off from the right one on consecutive sweeps; the consensus pose is the
    // least-squares fit of the agreeing matches.
    double fit = 0.0;
    if (by_consensus && have_consensus_pose) {
      T_hat[static_cast<std::size_t>(h)] = T_r;
      fit = fitness(T_r);
    } else {
      fit = fitness(T_hat[static_cast<std::size_t>(h)]);
      if (have_consensus_pose) {
        const double fit_r = fitness(T_r);
        if (fit_r > fit) {
          fit = fit_r;
          T_hat[static_cast<std::size_t>(h)] = T_r;
        }
      }
    }
    fit_of[static_cast<std::size_t>(h)] = fit;
    const double score = (by_consensus ? consensus_of[static_cast<std::size_t>(h)] : fit) *
                         (h == 0 ? impl_->opt.start_heading_margin : 1.0);
    score_of[static_cast<std::size_t>(h)] = score;
    if (score > best_score) {
      best_score = score;
      best = h;
    }
  }
  if (impl_->opt.teacher_refine) {
    // The teacher's refinement of the chosen pose, on the same normalised points.
    torch::Tensor labels;
    RigidTransforms T;
    {
      std::lock_guard<std::mutex> lock(impl_->mutex);
      T = teacherLabels(toTensor(src), toTensor(tgt),
                        fromIsometry(T_hat[static_cast<std::size_t>(best)]), impl_->opt.teacher,
                        labels);
    }
    T_hat[static_cast<std::size_t>(best)] = orthonormalized(toIsometry(T.R, T.t, 0));
    fit_of[static_cast<std::size_t>(best)] = fitness(T_hat[static_cast<std::size_t>(best)]);
  }
  const double best_fit = fit_of[static_cast<std::size_t>(best)];
  r.T_target_source = norm.denormalize(T_hat[static_cast<std::size_t>(best)]);
  r.fitness = best_fit;
  r.hypothesis_yaw_deg = 360.0 * best / H;
  // The network's own matches do not agree on any hypothesis: keep the start.
  const bool no_consensus = by_consensus && impl_->opt.min_consensus > 0.0 &&
                            consensus_of[static_cast<std::size_t>(best)] < impl_->opt.min_consensus;
  if (no_consensus) {
    r.T_target_source = norm.denormalize(Isometry3d::Identity());
    r.fitness = fitness(Isometry3d::Identity());
    r.hypothesis_yaw_deg = 0.0;
    r.kept_start = true;
  } else if (impl_->opt.keep_start_if_fitter) {
    const double start_fit = fitness(Isometry3d::Identity());
    if (start_fit > best_fit) {
      r.T_target_source = norm.denormalize(Isometry3d::Identity());
      r.fitness = start_fit;
      r.hypothesis_yaw_deg = 0.0;
      r.kept_start = true;
    }
  }
  r.hypotheses.resize(static_cast<std::size_t>(H));
  for (int h = 0; h < H; ++h) {
    YawHypothesis& y = r.hypotheses[static_cast<std::size_t>(h)];
    y.T_target_source = norm.denormalize(T_hat[static_cast<std::size_t>(h)]);
    y.yaw_deg = 360.0 * h / H;
    y.fitness = fit_of[static_cast<std::size_t>(h)];
    y.consensus = consensus_of[static_cast<std::size_t>(h)];
    y.score = score_of[static_cast<std::size_t>(h)];
    y.alpha = o.alpha[h].item<double>();
    y.overlap = o.overlap[h].item<double>();
    const auto w = o.weights[h].contiguous();
    const auto m = o.membership[h].contiguous();
    y.inlier_weights.assign(w.data_ptr<float>(), w.data_ptr<float>() + w.numel());
    y.overlap_membership.assign(m.data_ptr<float>(), m.data_ptr<float>() + m.numel());
  }
  // Best first by the score that chose; ties keep the yaw order, so hypotheses.front() is the
  // pass `best` chose.
  std::stable_sort(r.hypotheses.begin(), r.hypotheses.end(),
                   [](const YawHypothesis& a, const YawHypothesis& b) { return a.score > b.score; });
  r.alpha = r.hypotheses.front().alpha;
  r.overlap = r.hypotheses.front().overlap;
  r.inlier_weights = r.hypotheses.front().inlier_weights;
  r.overlap_membership = r.hypotheses.front().overlap_membership;
  r.runtime_ms = timer.ms();
  return r;
}

}  // namespace obm::obmnet
