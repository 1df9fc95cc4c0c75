// obm-bench: the registration benchmark (docs/metrics.md) of OBMNet against ICP and the classical
// peers, on generated object pairs or on a folder of pairs. See docs/obm-bench.md.
#include <CLI/CLI.hpp>
#include <algorithm>
#include <cstdio>
#include <iostream>
#include <memory>
#include <numeric>
#include <optional>
#include <random>
#include <sstream>
#include <string>
#include <vector>

#include "../common/cli.hpp"
#include "../common/paths.hpp"
#include "bench.hpp"
#include "obm/config/config_node.hpp"
#include "obm/core/atomic_file.hpp"
#include "obm/core/errors.hpp"
#include "obm/core/log.hpp"
#include "obm/datasets/fragment_source.hpp"
#include "obm/datasets/object_source.hpp"
#include "obm/datasets/scan_source.hpp"
#include "obm/obmnet/registrar.hpp"
#include "obm/registration/correlative_search.hpp"
#include "obm/registration/icp.hpp"
#include "obm/registration/obmnet_matcher.hpp"

using namespace obm;

namespace {

/// --pairs: clouds of at most this many points are fed to the network whole.
constexpr std::size_t kMaxWholePoints = 2048;

std::vector<std::string> splitList(const std::string& s) {
  std::vector<std::string> out;
  std::stringstream ss(s);
  for (std::string item; std::getline(ss, item, ',');)
    if (!item.empty()) out.push_back(item);
  return out;
}

/// How every network row runs the model (the command line's inference choices).
struct NetRun {
  std::string model;
  int threads = 2;
  int num_points = 0;
  int denoise = 0;
  int soft_sampling = -1;  ///< −1 = as the model file says, 0 = one-hot, 1 = relaxed (--sampling)
  int iterations = 0;      ///< registration iterations per pass; 0 = the model's (--iterations)
  /// σ of the matching map's spatial prior; −1 = the model's (--spatial-prior)
  double spatial_sigma = -1.0;
  int yaw_hypotheses = 0;  ///< 0 = the model's (--yaw-hypotheses)
  /// More starts of the `+icp-turns` rows: ± this about each of `start_turn_axes` (--start-turns)
  double start_turn_deg = 0.0;
  std::string start_turn_axes = "xy";
  int ransac = 0;          ///< RANSAC samples on the network's correspondences (--ransac)
  /// With `ransac`: hypotheses ranked by their RANSAC consensus (the +consensus rows, the library's
  /// default) or by their fitness (the +ransac rows).
  bool by_consensus = false;
  /// The start's heading kept unless another hypothesis scores this factor more
  /// (--start-heading-margin; 1 = no preference).
  double start_heading_margin = 1.0;
  /// The start kept below this consensus share (--min-consensus; 0 = off).
  double min_consensus = 0.0;
  /// The self-training teacher's refinement after the network (the `obmnet+teacher` row).
  bool teacher_refine = false;
  /// λ of the free-space choice among refined poses (--free-space; 0 = off).
  double free_space = 0.0;
  /// λ of the free-space ranking of the network's yaw hypotheses (--free-space-hypotheses).
  double free_space_hypotheses = 0.0;
  /// β of the starts' choice: confidence × (share of source inliers)^β (--choice-inliers).
  double choice_inliers = 0.0;
  /// The range images of both (a LiDAR's by default, a depth camera's for rgbd_frames).
  registration::FreeSpaceParams free_space_params;
};

/// `keep_start`: the network's start competes with its poses on their fitness
/// (ObmNetRegistrar::Options::keep_start_if_fitter), the `obmnet+verify` row.
bench::Method obmnetMethod(const std::string& name, const NetRun& net, bool keep_start = false) {
  obmnet::ObmNetRegistrar::Options o{net.model, net.num_points, net.threads, 0, net.denoise};
  o.soft_sampling = net.soft_sampling;
  o.iterations = net.iterations;
  o.spatial_sigma = net.spatial_sigma;
  o.yaw_hypotheses = net.yaw_hypotheses;
  o.ransac_iterations = net.ransac;
  o.select_by_consensus = net.by_consensus;
  o.start_heading_margin = net.start_heading_margin;
  o.min_consensus = net.min_consensus;
  o.keep_start_if_fitter = keep_start;
  if (net.teacher_refine) {
    // The teacher of the point-to-plane self-training config, read from it; every pair refined.
    o.teacher_refine = true;
    o.teacher = obmnet::TeacherParams::load(
        ConfigNode::loadFile(apps::findConfigFile("obmnet/train_objects_selftrain_plane.yaml"))
            .child("train")
            .child("teacher"));
  }
  auto reg = std::make_shared<obmnet::ObmNetRegistrar>(o);
  const double free_space = net.free_space_hypotheses;
  const registration::FreeSpaceParams free_space_params = net.free_space_params;
  return {name, [reg, free_space, free_space_params](const PointCloud& s, const PointCloud& t) {
            const obmnet::RegistrationResult r = reg->align(s, t);
            bench::MethodResult out(r.T_target_source);
            out.scores = {{"keypoint_fitness", r.fitness}, {"overlap", r.overlap}};
            std::size_t k = 0;  // the returned hypothesis
            if (free_space > 0.0 && r.hypotheses.size() > 1 && !r.kept_start) {
              // As the matcher ranks them (ObmNetMatcherParams::hypothesis_free_space_weight): the
              // registrar's ranking score discounted by the free-space conflicts.
              std::vector<Isometry3d> poses;
              std::vector<double> ranks;
              for (const auto& h : r.hypotheses) {
                poses.push_back(h.T_target_source);
                ranks.push_back(h.score);
              }
              const registration::FreeSpaceCheck check(s.points, t.points, free_space_params);
              k = registration::chooseByFreeSpace(poses, ranks, check, free_space);
              out.T_target_source = poses[k];
              out.scores = {{"keypoint_fitness", r.hypotheses[k].fitness},
                            {"overlap", r.hypotheses[k].overlap}};
            }
            // With RANSAC: the share of source points in the returned hypothesis's consensus.
            if (!r.hypotheses.empty() && r.hypotheses[k].consensus >= 0.0)
              out.scores.push_back({"consensus", r.hypotheses[k].consensus});
            return out;
          }};
}

/// Options of the project's ICP beyond its fixed object settings (0 = off each; IcpParams
/// explains them): the point-to-point polish down to a gate and a last stage with a narrower
/// kernel, in units of --unit, and the threshold below which a direction of the pose is held.
struct IcpFinish {
  double polish = 0.0;
  double final_kernel = 0.0;
  double weak = 0.0;
  int normal_neighbors = 10;  ///< k of the target's PCA normals
  double color_weight = 0.0;  ///< λ of coloured ICP's photometric term (used on coloured pairs)
  /// Grey residual an inlier may have on coloured pairs (ConfidenceParams::color_inlier_threshold;
  /// 0 = geometric inliers).
  double color_inlier = 0.0;
};

/// Point-to-plane ICP for unit-sphere objects: 0.1 correspondence gate annealed from 0.5, Huber
/// kernel at 0.02, up to 60 iterations, then the finishing stages. `unit` scales every length for
/// data in other units (the KITTI protocol's sparse 1024-point sweeps use unit = 20 m: a 2 m
/// gate, 0.4 m kernel).
registration::IcpParams objectIcpParams(double unit, const IcpFinish& finish) {
  registration::IcpParams p;
  p.initial_max_correspondence_distance = 0.5 * unit;
  p.max_correspondence_distance = 0.1 * unit;
  p.kernel_scale = 0.02 * unit;
  p.polish_max_correspondence_distance = finish.polish * unit;
  p.final_kernel_scale = finish.final_kernel * unit;
  p.weak_direction_threshold = finish.weak;
  p.normal_neighbors = finish.normal_neighbors;
  p.color_weight = finish.color_weight;
  p.max_iterations = 60;
  p.min_correspondences = 20;
  p.threads = 1;
  return p;
}

registration::ConfidenceParams objectConfidenceParams(double unit, const IcpFinish& finish) {
  registration::ConfidenceParams c;
  c.inlier_threshold = 0.05 * unit;
  c.min_sigma = 0.001 * unit;
  c.color_inlier_threshold = finish.color_inlier;
  return c;
}

std::shared_ptr<registration::IcpMatcher> objectIcpMatcher(double unit, const IcpFinish& finish) {
  return std::make_shared<registration::IcpMatcher>(objectIcpParams(unit, finish),
                                                    objectConfidenceParams(unit, finish));
}

/// A matcher's pose with its confidence scores: ICP's own fitness and inlier ratio, and for the
/// OBMNet matchers the bias-weighted confidence (MatchResult::network_confidence).
bench::MethodResult matchResult(const registration::MatchResult& r) {
  bench::MethodResult out(r.T_target_source);
  out.scores = {{"fitness", r.fitness}, {"inlier_ratio", r.inlier_ratio}};
  if (r.alpha != 1.0 || r.network_confidence >= 0.0)
    out.scores.push_back({"obm_confidence", std::max(0.0, r.network_confidence)});
  return out;
}

/// A bench row that runs `matcher` from the identity.
bench::Method matcherMethod(std::string name,
                            std::shared_ptr<const registration::ScanMatcher> matcher) {
  return {std::move(name), [matcher](const PointCloud& s, const PointCloud& t) {
            return matchResult(matcher->match(s, t, Isometry3d::Identity()));
          }};
}

/// The refinement after the network: the same ICP without the coarse start. The network leaves a
/// few degrees (≈ 0.05 at the unit sphere's surface), well inside the final 0.1 gate; a 0.5 start
/// gate would pair the parts outside the overlap of partial pairs and pull the pose off.
registration::IcpParams objectRefineIcpParams(double unit, const IcpFinish& finish) {
  registration::IcpParams p = objectIcpParams(unit, finish);
  p.initial_max_correspondence_distance = p.max_correspondence_distance;
  return p;
}

/// The settings of the `obmnet+icp` rows' matcher (the network as `net` says, then the
/// refinement's narrow ICP).
registration::ObmNetMatcherParams obmnetIcpParams(const NetRun& net, double unit,
                                                  const IcpFinish& finish, double overlap_keep,
                                                  int refine_hypotheses = 1,
                                                  int init_headings = 0, bool pre_align = false) {
  registration::ObmNetMatcherParams p;
  p.refine_hypotheses = refine_hypotheses;
  p.init_headings = init_headings;
  // The blind headings start as the `icp` row does (its wide gate), the network's poses narrow.
  p.init_headings_gate = objectIcpParams(unit, finish).initial_max_correspondence_distance;
  p.denoise_neighbors = net.denoise;
  p.soft_sampling = net.soft_sampling;
  p.iterations = net.iterations;
  p.spatial_sigma = net.spatial_sigma;
  p.yaw_hypotheses = net.yaw_hypotheses;
  p.start_turn_deg = net.start_turn_deg;
  p.start_turn_axes = net.start_turn_axes;
  p.ransac_iterations = net.ransac;
  p.select_by_consensus = net.by_consensus;
  p.start_heading_margin = net.start_heading_margin;
  p.model_path = net.model;
  p.num_points = net.num_points;
  p.threads = net.threads;
  p.pre_align = pre_align;
  p.keep_init_if_better = false;
  p.overlap_stage_keep = overlap_keep;
  p.choice_free_space_weight = net.free_space;
  p.hypothesis_free_space_weight = net.free_space_hypotheses;
  p.choice_inlier_power = net.choice_inliers;
  p.free_space = net.free_space_params;
  return p;
}

std::shared_ptr<registration::ObmNetIcpMatcher> obmnetIcpMatcher(
    const registration::ObmNetMatcherParams& p, double unit, const IcpFinish& finish) {
  return std::make_shared<registration::ObmNetIcpMatcher>(p, objectRefineIcpParams(unit, finish),
                                                          objectConfidenceParams(unit, finish));
}

std::shared_ptr<registration::ObmNetIcpMatcher> obmnetIcpMatcher(const NetRun& net, double unit,
                                                                 const IcpFinish& finish,
                                                                 double overlap_keep,
                                                                 int refine_hypotheses = 1,
                                                                 int init_headings = 0) {
  return obmnetIcpMatcher(
      obmnetIcpParams(net, unit, finish, overlap_keep, refine_hypotheses, init_headings), unit,
      finish);
}

/// The refinement after the network on its own (narrow gate): `icp@truth`, `o3d_fgr+obm_icp`.
std::shared_ptr<registration::IcpMatcher> objectRefineIcpMatcher(double unit,
                                                                 const IcpFinish& finish) {
  return std::make_shared<registration::IcpMatcher>(objectRefineIcpParams(unit, finish),
                                                    objectConfidenceParams(unit, finish));
}

/// ICP from each of `starts` against one prepared target, keeping the result with the largest
/// inlier ratio (ICP's own score; the network's rows use their confidence): the classical rows
/// with several starts.
/// With `free_space` > 0 (sensor sweeps), the inlier ratio is discounted by the pose's free-space
/// conflicts as the matcher's choice is (ObmNetMatcherParams::choice_free_space_weight).
bench::MethodResult bestIcpOfStarts(const registration::ScanMatcher& icp, const PointCloud& s,
                                    const PointCloud& t, const std::vector<Isometry3d>& starts,
                                    double free_space = 0.0,
                                    const registration::FreeSpaceParams& free_space_params = {}) {
  std::optional<registration::MatchResult> best;
  double best_score = -1.0;
  const registration::PreparedTarget target = icp.prepare(t);  // once for all starts
  std::optional<registration::FreeSpaceCheck> check;
  if (free_space > 0.0) check.emplace(s.points, t.points, free_space_params);
  for (const Isometry3d& T0 : starts) {
    registration::MatchResult r = icp.match(s, target, T0);
    if (r.status == registration::MatchStatus::TooFewCorrespondences) continue;
    const double score =
        r.inlier_ratio *
        (check ? std::max(0.0, 1.0 - free_space * check->conflicts(r.T_target_source).ratio())
               : 1.0);
    if (!best || score > best_score) {
      best = std::move(r);
      best_score = score;
    }
  }
  if (!best) best = icp.match(s, target, Isometry3d::Identity());
  return matchResult(*best);
}

/// The classical counterpart of the network's yaw hypotheses (`icp-yaw4`): ICP from the identity
/// turned by 0°, 90°, 180° and 270° about the source frame's z axis (the sensor's vertical for a
/// sweep). Shows what the network's poses add over trying the same headings blindly.
bench::Method icpYawMethod(std::shared_ptr<const registration::ScanMatcher> icp, int headings) {
  return {"icp-yaw" + std::to_string(headings),
          [icp, headings](const PointCloud& s, const PointCloud& t) {
            std::vector<Isometry3d> starts;
            for (int h = 0; h < headings; ++h)
              starts.push_back(
                  makeIsometry(Eigen::AngleAxisd(2.0 * 3.14159265358979323846 * h / headings,
                                                 Eigen::Vector3d::UnitZ())
                                   .toRotationMatrix(),
                               Eigen::Vector3d::Zero()));
            return bestIcpOfStarts(*icp, s, t, starts);
          }};
}

/// The classical counterpart of the matcher's start turns (`icp-turns`): ICP from the identity
/// and from the identity turned by ±`deg` about each of `axes` of the source frame.
bench::Method icpTurnsMethod(std::shared_ptr<const registration::ScanMatcher> icp, double deg,
                             const std::string& axes) {
  return {"icp-turns", [icp, deg, axes](const PointCloud& s, const PointCloud& t) {
            std::vector<Isometry3d> starts{Isometry3d::Identity()};
            for (const Isometry3d& turn : registration::startTurns(deg, axes))
              starts.push_back(turn);
            return bestIcpOfStarts(*icp, s, t, starts);
          }};
}

/// A classical global start for the network (`obmnet+icp-turns+fgr`): the network + ICP from
/// its own starts (`turns`, from the identity) and from a global method's pose (`global`, e.g.
/// Open3D's FGR; `from_start` sees the source moved by it and corrects it), keeping the result
/// with the higher bias-weighted confidence (times the inlier ratio to the power
/// `choice_inliers`, as the matcher's own starts compete: ObmNetMatcherParams::
/// choice_inlier_power). What the network and its confidence add to a feature-based start.
/// Without `turns` (`obmnet+icp@fgr`): the network + ICP from the global pose alone.
bench::Method globalStartMethod(const std::string& name,
                                std::shared_ptr<const registration::ScanMatcher> turns,
                                std::shared_ptr<const registration::ScanMatcher> from_start,
                                bench::Method global, double choice_inliers) {
  return {name, [turns, from_start, global, choice_inliers](const PointCloud& s,
                                                            const PointCloud& t) {
            const Isometry3d T_global = global.fn(s, t).T_target_source;
            registration::MatchResult b = from_start->match(s, t, T_global);
            if (!turns) return matchResult(b);
            registration::MatchResult a = turns->match(s, t, Isometry3d::Identity());
            auto score = [choice_inliers](const registration::MatchResult& r) {
              return registration::startChoiceScore(r.network_confidence, r.inlier_ratio,
                                                    choice_inliers);
            };
            const bool take_b = b.status != registration::MatchStatus::TooFewCorrespondences &&
                                b.status != registration::MatchStatus::TooFewPoints &&
                                score(b) > score(a);
            return matchResult(take_b ? b : a);
          }};
}

/// The correlative search's poses (registration::correlativeSearch), best first.
std::vector<Isometry3d> searchPoses(const PointCloud& s, const PointCloud& t,
                                    const registration::CorrelativeSearchParams& p) {
  std::vector<Isometry3d> out;
  for (const auto& h : registration::correlativeSearch(s, t, p)) out.push_back(h.T_target_source);
  return out;
}

/// The classical chain on the same starts (`search+icp`): the refinement of `obmnet+icp` from
/// each of the search's poses.
bench::Method searchIcpMethod(std::shared_ptr<const registration::ScanMatcher> refine,
                              const registration::CorrelativeSearchParams& p, double free_space,
                              const registration::FreeSpaceParams& free_space_params) {
  return {"search+icp",
          [refine, p, free_space, free_space_params](const PointCloud& s, const PointCloud& t) {
            return bestIcpOfStarts(*refine, s, t, searchPoses(s, t, p), free_space,
                                   free_space_params);
          }};
}

/// Both starts a user without a prior has: the network's pose (then the refinement, as
/// `obmnet+icp`) and the identity (the `icp` row); the result that pairs more source points within
/// the final gate wins. Neither start sees the ground truth; it costs both rows' time.
bench::Method obmnetIcpOrIcpMethod(std::shared_ptr<const registration::ScanMatcher> net,
                                   std::shared_ptr<const registration::ScanMatcher> icp) {
  return {"obmnet+icp|icp", [net, icp](const PointCloud& s, const PointCloud& t) {
            const registration::MatchResult a = net->match(s, t, Isometry3d::Identity());
            const registration::MatchResult b = icp->match(s, t, Isometry3d::Identity());
            auto paired = [](const registration::MatchResult& r) {
              return r.status != registration::MatchStatus::TooFewCorrespondences &&
                     r.status != registration::MatchStatus::EmptyInput &&
                     r.status != registration::MatchStatus::TooFewPoints;
            };
            const bool take_b = paired(b) && (!paired(a) ||
                                              b.num_correspondences > a.num_correspondences);
            return matchResult(take_b ? b : a);
          }};
}

/// The Overlap Bias Matching Module as a plug-in (`obmm+icp`): ICP from the identity whose
/// residuals are weighted by the module's ω (ObmmIcpMatcher); the same ICP as the `icp` row.
std::shared_ptr<registration::ObmmIcpMatcher> obmmIcpMatcher(const std::string& model, int threads,
                                                             int num_points, double unit,
                                                             const IcpFinish& finish) {
  registration::ObmNetMatcherParams p;
  p.model_path = model;
  p.num_points = num_points;
  p.threads = threads;
  p.pre_align = false;
  return std::make_shared<registration::ObmmIcpMatcher>(p, objectIcpParams(unit, finish),
                                                        objectConfidenceParams(unit, finish));
}

/// `obmm+<peer>`: the peer (FGR or RANSAC on FPFH) on the points the module predicts in the
/// overlap only — the fraction `keep` of each cloud's network points with the largest ω.
bench::Method overlapRestricted(std::string name,
                                std::shared_ptr<const registration::OverlapPredictor> pred,
                                bench::Method peer, double keep) {
  return {std::move(name), [pred, peer, keep](const PointCloud& s, const PointCloud& t) {
            const registration::OverlapPrediction o = pred->predict(s, t);
            auto top = [keep](const std::vector<Vector3f>& pts, const std::vector<double>& w) {
              std::vector<std::size_t> order(pts.size());
              std::iota(order.begin(), order.end(), std::size_t{0});
              const auto n = std::max<std::size_t>(
                  8, static_cast<std::size_t>(std::lround(keep * static_cast<double>(pts.size()))));
              std::stable_sort(order.begin(), order.end(),
                               [&](std::size_t a, std::size_t b) { return w[a] > w[b]; });
              PointCloud c;
              for (std::size_t i = 0; i < std::min(n, order.size()); ++i)
                c.points.push_back(pts[order[i]]);
              return c;
            };
            return peer.fn(top(o.source_points, o.source_weights),
                           top(o.target_points, o.target_weights));
          }};
}

bench::Open3dParams scaledOpen3dParams(double unit) {
  bench::Open3dParams p;
  p.voxel *= unit;
  p.normal_radius *= unit;
  p.feature_radius *= unit;
  p.icp_max_distance *= unit;
  p.ransac_max_distance *= unit;
  return p;
}

}  // namespace

int main(int argc, char** argv) {
  obm::apps::useFastMathLibraries(argv);
  CLI::App app{
      "obm-bench: registration benchmark. Scores OBMNet, OBMNet + point-to-plane ICP, ICP alone "
      "and\n"
      "(when built with Open3D) Open3D's ICP, FGR and RANSAC + FPFH on the same pairs, with "
      "RIENet's\n"
      "metrics: MAE(R), MAE(t), MIE(R) [deg], MIE(t), recall, median ms/pair.\n"
      "Pairs come from --pairs DIR (pair_NNNN_src.ply, pair_NNNN_tgt.ply, gt.txt: id + 12 numbers "
      "of\n"
      "T_tgt_src row-major) or are generated from the object set by --protocol and --group."};
  std::string pairs_dir, json_out, md_out, per_pair_out, write_pairs, methods_arg, ablation,
      log_level;
  std::string config_path = "", model = "";
  std::string protocol = "clean", group = "unseen";
  int n_pairs = 200, threads = 2, num_points = -1, denoise = 0, sweep_points = 0;
  std::uint64_t seed = 1;
  double recall_deg = 1.0, recall_trans = 0.1, jitter_sigma = -1.0, unit = 0.0, polish = -1.0,
         final_kernel = -1.0, overlap_keep = -1.0, weak_threshold = 0.0;
  std::vector<std::string> sequences;
  std::string pair_class, frame_gaps;
  bool quiet = false;
  app.add_option("--pairs", pairs_dir, "score the pairs in this folder instead of generated ones");
  app.add_option("--json", json_out, "write the results as JSON");
  app.add_option("--markdown", md_out, "write the table as Markdown");
  app.add_option("--per-pair", per_pair_out,
                 "write every pair's errors as CSV: pair, name, overlap, then per method RRE "
                 "[deg], RTE, ms and ok (within the recall thresholds)");
  app.add_option("--model", model,
                 "OBMNet model file (default by data kind, from share/obmslam/models: "
                 "obmnet_objects.pt for clean and partial, obmnet_objects_noise.pt for jitter, "
                 "outliers and partial_noise, obmnet_objects_resampled.pt for resampled and "
                 "--pairs, obmnet_indoor.pt for indoor, icl and rgbd_frames, obmnet_lidar.pt for "
                 "kitti)");
  app.add_option("--config", config_path,
                 "YAML with a `data:` map for the object set (default: the training config)");
  app.add_option("--protocol", protocol,
                 "clean | jitter | outliers | partial | partial_noise | resampled | indoor | icl | "
                 "rgbd_frames | kitti (resampled: independent samplings of each object, no shared "
                 "point; rgbd_frames: two different depth frames, --config "
                 "config/obmnet/train_indoor.yaml, --group val|unseen; indoor, "
                 "icl: 2048-point fragments, e.g. with --config config/obmnet/train_indoor.yaml; "
                 "kitti: RIENet's (i, i+10) LiDAR pairs of --sequence folders, see "
                 "config/obmnet/train_lidar.yaml)")
      ->capture_default_str();
  app.add_option("--jitter", jitter_sigma,
                 "per-point Gaussian jitter σ of both clouds, overriding the protocol's (clipped "
                 "at 5σ of RIENet's 0.01/0.05 ratio); a sensitivity sweep");
  app.add_option("--group", group,
                 "seen (training objects, new poses) | val (the validation split) | unseen "
                 "(held-out test objects)")
      ->capture_default_str();
  app.add_option("-n,--num-pairs", n_pairs, "generated pairs")->capture_default_str();
  app.add_option("--seed", seed, "seed of the generated pairs")->capture_default_str();
  app.add_option("--methods", methods_arg, "comma-separated subset (default: all available)");
  app.add_option("--ablation", ablation,
                 "comma-separated model files: one row per model (OS/BP/NMM variants)");
  app.add_option("--sequence", sequences,
                 "kitti protocol: a KITTI odometry folder with poses.txt (repeatable); default: the "
                 "config's val_sequences with --group val");
  app.add_option("--pair-class", pair_class,
                 "kitti protocol: k1, k5, k10, k20 (pairs (i, i+k)) or loop (revisits of a place "
                 "within the config's loop_max_distance, spread over yaw differences 0-180 deg); "
                 "default: the config's frame_gap");
  app.add_option("--frame-gaps", frame_gaps,
                 "rgbd_frames protocol: MIN:MAX frames between the two depth frames of a pair "
                 "(default 5:30)");
  app.add_option("--unit", unit,
                 "length [cloud units] that scales the ICP and Open3D peers' distances, which are "
                 "set for unit-sphere objects (default: 1; 20 for the kitti protocol, in metres)");
  app.add_option("--icp-polish", polish,
                 "gate [units of --unit] of the point-to-point polish after the project's ICP (0 = "
                 "off); default 0.05 for the generated protocols (object and fragment pairs), "
                 "whose two clouds carry the same surface samples, else 0 (see docs/obm-bench.md)");
  app.add_option("--icp-final-kernel", final_kernel,
                 "kernel scale [units of --unit] of a last stage of the project's ICP at its fine "
                 "gate (0 = off); default 0.005 for the resampled protocol (independent samplings "
                 "of objects), else 0 (see docs/obm-bench.md)")
      ->check(CLI::NonNegativeNumber);
  app.add_option("--icp-weak", weak_threshold,
                 "the project's ICP: directions of the pose whose normalised Hessian eigenvalue "
                 "is below this are not moved (0 = off; see docs/obm-bench.md)")
      ->check(CLI::Range(0.0, 0.999))
      ->capture_default_str();
  int icp_normal_neighbors = 0;
  app.add_option("--icp-normal-neighbors", icp_normal_neighbors,
                 "the project's ICP: k nearest target points of each PCA normal; default 10 (the "
                 "1024-point objects), 30 for the rgbd_frames protocol (dense depth frames on a "
                 "1 cm grid: a wider patch against the depth noise, see docs/obm-bench.md)")
      ->check(CLI::Range(3, 1000));
  double icp_color_weight = -1.0;
  app.add_option("--icp-color-weight", icp_color_weight,
                 "the project's ICP (every ICP row and the refinement after the network): weight "
                 "λ of coloured ICP's grey-level term on pairs whose clouds carry colours (the "
                 "rgbd_frames protocol); 0 = geometric ICP; default 0.1 for rgbd_frames with "
                 "colour images, else 0 (see docs/obm-bench.md)")
      ->check(CLI::NonNegativeNumber);
  double color_inlier = -1.0;
  app.add_option("--color-inlier", color_inlier,
                 "with coloured ICP: grey residual [0-1] an inlier may have, so that the "
                 "inlier counts and the network's confidence that choose between starts ask "
                 "the colours to agree too (0 = geometric inliers; default 0.05 with coloured "
                 "ICP, see docs/obm-bench.md)")
      ->check(CLI::NonNegativeNumber);
  app.add_option("--overlap-stage", overlap_keep,
                 "obmnet+icp: fraction of the network's points, those with the largest SVD "
                 "weights, refined first by an ICP of their own (0 = off; default 0.5, see "
                 "docs/obm-bench.md)");
  app.add_option("--recall-deg", recall_deg, "recall: RRE below this [deg]")->capture_default_str();
  app.add_option("--recall-trans", recall_trans, "recall: RTE below this [units]")
      ->capture_default_str();
  double surface_error = 0.005;
  app.add_option("--surface-error", surface_error,
                 "generated object pairs: also the recall up to the object's symmetries, a pair "
                 "counting as registered when the object placed by the estimate lies within this "
                 "mean distance of the object placed by the truth (docs/metrics.md; 0 = off)")
      ->check(CLI::NonNegativeNumber)
      ->capture_default_str();
  app.add_option("--write-pairs", write_pairs,
                 "also write the pairs to this folder (readable by --pairs)");
  app.add_option("--threads", threads, "threads for the network")->capture_default_str();
  app.add_option("--sweep-points", sweep_points,
                 "kitti protocol: voxel keypoints per sweep given to every method (default: the "
                 "config's train.pairs.num_points); with a larger value than --num-points the "
                 "network samples its own points from them, e.g. above the road for a model "
                 "trained with ground_band");
  app.add_option("--num-points", num_points,
                 "points per cloud the network samples (clouds with fewer are kept whole); "
                 "default: every generated cloud whole (crops and outliers included); for "
                 "--pairs every cloud whole when none has more than 2048 points, else the "
                 "model's (0 = the model's)");
  app.add_option("--denoise", denoise,
                 "neighbour-mean denoising of the network's inputs: each point averaged with its "
                 "K nearest neighbours (0 = off; for jittered clouds)")
      ->capture_default_str();
  std::string sampling = "model";
  app.add_option("--sampling", sampling,
                 "the network's overlap sampling at inference: model (as the model file says), "
                 "hard (one-hot draws) or soft (the relaxed draws of training)")
      ->check(CLI::IsMember({"model", "hard", "soft"}))
      ->capture_default_str();
  int iterations = 0, yaw_hypotheses = 0, ransac = 5000;
  app.add_option("--ransac", ransac,
                 "RANSAC samples of the obmnet+ransac rows: a consensus pose from the network's "
                 "correspondences (each source point and its 4 most probable target points), "
                 "competing with its weighted SVD")
      ->check(CLI::NonNegativeNumber)
      ->capture_default_str();
  app.add_option("--iterations", iterations,
                 "registration iterations of each network pass (0 = the model's n_iters; the "
                 "iterations share their weights, so more than training ran is allowed)")
      ->check(CLI::NonNegativeNumber)
      ->capture_default_str();
  double spatial_sigma = -1.0;
  app.add_option("--spatial-prior", spatial_sigma,
                 "σ of a Gaussian prior on the network's matches around each source point's "
                 "current place, in the network's normalised units (0 = off; default: the "
                 "model's), so a pass corrects the given start instead of matching across the "
                 "whole cloud (see docs/model.md)")
      ->check(CLI::NonNegativeNumber);
  app.add_option("--yaw-hypotheses", yaw_hypotheses,
                 "sources turned by 360°/H about z before the network, all H in one batch (0 = "
                 "the model's: 4 for a planar LiDAR model, else 1)")
      ->check(CLI::NonNegativeNumber)
      ->capture_default_str();
  double start_turns = 0.0;
  std::string start_turn_axes = "xy";
  app.add_option("--start-turns", start_turns,
                 "adds the rows obmnet+icp-turns and icp-turns: the network + ICP (and ICP) also "
                 "from the start turned by ± this many degrees about each axis of "
                 "--start-turn-axes, keeping the most confident result (0 = off); with Open3D "
                 "also obmnet+icp-turns+fgr and obmnet+icp@fgr (FGR's pose as a start)")
      ->check(CLI::Range(0.0, 180.0))
      ->capture_default_str();
  app.add_option("--start-turn-axes", start_turn_axes,
                 "the source-frame axes of --start-turns (any of x, y, z; camera: x right, y "
                 "down)")
      ->capture_default_str();
  std::string start_near;
  app.add_option("--start-near", start_near,
                 "DEG,M: every pair starts near its answer instead of where it was given, the "
                 "source moved by the ground truth times a random turn of up to DEG degrees and "
                 "shift of up to M (the pairs' units), drawn from --seed: what each method does "
                 "from a right start (the identity row is then that start)");
  std::string search_axis, search_range;
  double search_cell = 0.0;
  double search_step = 0.0;
  double choice_plane = -1.0;
  double choice_inliers = -1.0;
  double free_space = -1.0;
  double free_space_hypotheses = 0.0;
  double start_heading_margin = -1.0;
  double min_consensus = -1.0;
  int search_points = 0;
  int search_candidates = 0;  // 0: by the pairs' kind (below)
  int search_shifts = 0;
  double search_color = 0.05;
  app.add_option("--search-axis", search_axis,
                 "the turn axis of the search rows (search, search+icp, obmnet+icp+search, "
                 "obmnet+icp-turns+fgr+search) in the source frame: x, y or z, or any (every "
                 "rotation within the range; turns about the source's centroid, translations "
                 "from where the centroids meet) (default: y for rgbd_frames, a camera's "
                 "vertical; z for kitti; any for objects and fragments)");
  app.add_option("--search-range", search_range,
                 "DEG,M[,AXIAL]: the search covers headings within ±DEG about --search-axis and "
                 "translations within ±M along each axis, ±AXIAL along the turn axis itself "
                 "(default: 60,1 for rgbd_frames, 180,20,1 for kitti, else 90,0.3 times --unit)");
  app.add_option("--search-step", search_step,
                 "spacing of the search's turns [deg] (default: 3 about one axis, 7.5 with "
                 "--search-axis any)")
      ->check(CLI::PositiveNumber);
  app.add_option("--search-cell", search_cell,
                 "the search's grid cell and translation step, in the pairs' units (default: 1 m "
                 "for kitti, 0.1 times --unit for objects and fragments, else the translation "
                 "range / 10)")
      ->check(CLI::PositiveNumber);
  app.add_option("--search-shifts", search_shifts,
                 "translations the search keeps per heading before ranking all its poses "
                 "(default: 10 for kitti, 3 for other sensor frames, 1 for objects and "
                 "fragments)")
      ->check(CLI::PositiveNumber);
  app.add_option("--search-color", search_color,
                 "grey-level tolerance of the search's occupancy on coloured pairs (0 = off): a "
                 "point on an occupied cell of another grey counts half")
      ->check(CLI::Range(0.0, 1.0))
      ->capture_default_str();
  app.add_option("--search-points", search_points,
                 "source points the search scores (default: 1000 for sensor frames, 300 for "
                 "objects and fragments, whose search turns over every rotation)")
      ->check(CLI::PositiveNumber);
  app.add_option("--choice-plane", choice_plane,
                 "the search rows: starts compete on points within this distance [units of "
                 "--unit] of the target's tangent planes (ObmNetMatcherParams::"
                 "choice_plane_distance; search+icp: its inliers within it); 0 = the confidence's "
                 "inlier threshold (default: 0.01 for object and fragment pairs, else 0)")
      ->check(CLI::NonNegativeNumber);
  app.add_option("--choice-inliers", choice_inliers,
                 "the network rows with several starts (start turns, FGR's pose, the search's "
                 "poses): they compete on the bias-weighted confidence times the share of all "
                 "source points that are inliers at the pose, to this power "
                 "(ObmNetMatcherParams::choice_inlier_power); 0 = the confidence alone "
                 "(default: 1 for rgbd_frames, else 0)")
      ->check(CLI::NonNegativeNumber);
  app.add_option("--free-space", free_space,
                 "sensor sweeps: weight λ of the free-space test (docs/registration.md, \"Free "
                 "space\"): the refined poses compete with their score times max(0, 1 - λ·r), "
                 "r the share of both sweeps' points a pose puts where the other sweep looked "
                 "through (the obmnet+icp rows with several refinements, search+icp); 0 = off "
                 "(default: 8 for kitti, else 0)")
      ->check(CLI::NonNegativeNumber);
  app.add_option("--start-heading-margin", start_heading_margin,
                 "several yaw hypotheses: the start's heading is kept unless another scores "
                 "more than this factor times it (ObmNetMatcherParams::start_heading_margin; "
                 "every network row); 1 = no preference (default: 1.25 for kitti, else 1)")
      ->check(CLI::Range(1.0, 1e9));
  app.add_option("--min-consensus", min_consensus,
                 "the network rows without ICP (obmnet+consensus): below this share of source "
                 "points in the chosen hypothesis's RANSAC consensus the network keeps the start "
                 "(ObmNetMatcherParams::min_consensus); 0 = off (default: 0.06 for kitti, else 0)")
      ->check(CLI::Range(0.0, 1.0));
  app.add_option("--free-space-hypotheses", free_space_hypotheses,
                 "sensor sweeps: weight λ of the free-space ranking of the network's yaw "
                 "hypotheses (ObmNetMatcherParams::hypothesis_free_space_weight; every network "
                 "row); 0 = off")
      ->check(CLI::NonNegativeNumber)
      ->capture_default_str();
  app.add_option("--search-candidates", search_candidates,
                 "poses the search hands on to the refinement, best first (default: 16 for "
                 "rgbd_frames, 8 for kitti, 32 for objects and fragments)")
      ->check(CLI::PositiveNumber);
  app.add_flag("-q,--quiet", quiet, "no progress bars");
  apps::addLogLevelOption(app, log_level, "warn");
  CLI11_PARSE(app, argc, argv);

  return apps::runMain("obm-bench", apps::OtherExceptions::Error, [&] {
    setLogLevel(parseLogLevel(log_level));
    OBM_LOG_DEBUG("obm-bench", "math libraries: " << apps::mathLibrarySettings());
    if (model.empty()) {
      // The model of the data's kind; pairs of unknown origin (--pairs) and noisy protocols get
      // a model trained on noise (the noise-free one fails on any jittered cloud).
      const std::string kind =
          !pairs_dir.empty()                                             ? "obmnet_objects_resampled"
          : protocol == "kitti"                                          ? "obmnet_lidar"
          : protocol == "rgbd_frames" || protocol == "indoor" || protocol == "icl" ? "obmnet_indoor"
          : protocol == "resampled"                                      ? "obmnet_objects_resampled"
          : protocol == "jitter" || protocol == "outliers" || protocol == "partial_noise"
              ? "obmnet_objects_noise"
              : "obmnet_objects";
      model = apps::findShareFile("models/" + kind + ".pt");
      OBM_LOG_INFO("obm-bench", "model: " << model << " (the default for "
                                          << (pairs_dir.empty() ? "--protocol " + protocol
                                                                : std::string("--pairs"))
                                          << "; --model to choose another)");
    }
    std::vector<obmnet::RegistrationPair> pairs;
    std::string info;
    bool shared_samples = false;  // set where pairs are generated by obmnet::makePair
    bool independent_objects = false;  // the resampled protocol: each cloud sampled on its own
    // Generated object pairs: the scorer of each pair's object (surface error up to symmetry).
    std::vector<std::unique_ptr<eval::SurfaceErrorScorer>> object_scorers;
    std::vector<const eval::SurfaceErrorScorer*> scorer_of_pair;
    bool feed_whole = false;      // generated object / fragment pairs: no sub-sampling
    if (!pairs_dir.empty()) {
      pairs = bench::readPairFolder(pairs_dir);
      info = "pairs from " + pairs_dir;
    } else if (protocol == "rgbd_frames") {
      // Two different depth frames of an RGB-D sequence, each in its own camera frame, in metres.
      if (config_path.empty()) config_path = apps::findConfigFile("obmnet/train_indoor.yaml");
      const auto root = ConfigNode::loadFile(config_path);
      const auto data = root.child("data");
      std::string dir;
      data.get("dir", dir);
      const auto opts = datasets::RgbdFragmentOptions::load(data.child("rgbd"));
      if (group != "val" && group != "unseen")
        throw ConfigError("--protocol rgbd_frames: --group must be val or unseen, not '" + group + "'");
      const auto& seqs = group == "val" ? opts.val_sequences : opts.test_sequences;
      int lo = 5, hi = 30;
      if (!frame_gaps.empty() &&
          std::sscanf(frame_gaps.c_str(), "%d:%d", &lo, &hi) != 2)
        throw ConfigError("--frame-gaps: expected MIN:MAX, got '" + frame_gaps + "'");
      // With their colours: the coloured ICP rows use them, every other method sees geometry.
      pairs = datasets::rgbdFramePairs(dir, opts, seqs, lo, hi, n_pairs, seed, true);
      if (icp_normal_neighbors <= 0) icp_normal_neighbors = 30;
      if (!app.count("--recall-deg")) recall_deg = 5.0;
      if (!app.count("--recall-trans")) recall_trans = 0.1;
      std::ostringstream os;
      os << "protocol rgbd_frames (frames i, i+s, s in [" << lo << ", " << hi << "]), "
         << pairs.size() << " pairs of the " << group << " sequences of " << config_path
         << ", voxel " << opts.voxel << " m, seed " << seed << ", ICP normals from "
         << icp_normal_neighbors << " neighbours";
      info = os.str();
    } else if (protocol == "kitti") {
      // RIENet's KITTI protocol: pairs (i, i + frame_gap) of sweeps, each voxelised and sampled
      // to the config's points, scored against the sequences' ground truth.
      if (config_path.empty()) config_path = apps::findConfigFile("obmnet/train_lidar.yaml");
      const auto root = ConfigNode::loadFile(config_path);
      auto scans = datasets::ScanSourceConfig::load(root.child("data"));
      // Every method sees whole sweeps: a model trained without the road cuts it itself
      // (model.ground_band, recorded in the model file).
      scans.ground_band = 0.0;
      if (!sequences.empty()) {
        scans.val_sequences = sequences;
      } else if (group != "val") {
        throw ConfigError("--protocol kitti: give the test sequences with --sequence DIR (the "
                          "config's val_sequences are used only with --group val)");
      }
      int scan_points = 1024;
      root.child("train").child("pairs").get("num_points", scan_points);
      if (sweep_points > 0) scan_points = sweep_points;
      const auto cls = pair_class.empty() ? datasets::ScanPairClass{scans.frame_gap, false}
                                          : datasets::ScanPairClass::parse(pair_class);
      pairs = datasets::scanPairs(scans, scans.val_sequences, cls, scan_points, n_pairs, seed);
      if (num_points < 0) num_points = scan_points;
      if (unit <= 0.0) unit = 20.0;
      if (!app.count("--recall-deg")) recall_deg = 5.0;  // RIENet's KITTI recall: 5° and 2 m
      if (!app.count("--recall-trans")) recall_trans = 2.0;
      std::string names;
      for (const auto& q : scans.val_sequences) names += (names.empty() ? "" : ", ") + q;
      std::ostringstream os;
      os << "protocol kitti "
         << (cls.loop ? std::string("loop pairs (revisits)")
                      : "(i, i+" + std::to_string(cls.gap) + ")")
         << ", " << pairs.size() << " pairs of "
         << names << ", " << scan_points << " points per sweep after a " << scans.voxel
         << " m voxel grid, seed " << seed;
      info = os.str();
    } else {
      if (config_path.empty()) config_path = apps::findConfigFile("obmnet/train_objects.yaml");
      const auto root = ConfigNode::loadFile(config_path);
      auto proto = obmnet::PairProtocol::preset(protocol);
      auto source_cfg = datasets::ObjectSourceConfig::load(root.child("data"));
      // Independent samplings draw source and target from disjoint halves of every surface
      // sample of the object, so the whole sample is kept.
      if (proto.resample && source_cfg.source != "modelnet40" && source_cfg.source != "rgbd")
        source_cfg.objects.keep_points = source_cfg.objects.surface_points;
      // Dense reference samples of every mesh for the surface error (8192: the floor of a
      // symmetry stays below 0.001 on a box, docs/metrics.md); the pairs do not change.
      if (surface_error > 0.0) source_cfg.objects.reference_points = 8192;
      auto set = datasets::loadObjectSet(source_cfg);
      if (group != "seen" && group != "val" && group != "unseen")
        throw ConfigError("--group must be seen, val or unseen, not '" + group + "'");
      const auto& objects = group == "seen" ? set.train : group == "val" ? set.val : set.test;
      const auto& references = group == "seen" ? set.train_reference
                               : group == "val" ? set.val_reference
                                                : set.test_reference;
      if (objects.empty()) throw Error("no objects in the " + group + " group");
      // Mesh sources have reference samples; ModelNet40's point sets and RGB-D fragments not.
      if (references.size() == objects.size()) {
        const auto used = std::min(objects.size(), static_cast<std::size_t>(n_pairs));
        for (std::size_t o = 0; o < used; ++o)
          object_scorers.push_back(std::make_unique<eval::SurfaceErrorScorer>(references[o]));
        for (int i = 0; i < n_pairs; ++i)
          scorer_of_pair.push_back(
              object_scorers[static_cast<std::size_t>(i) % objects.size()].get());
      }
      // The point-to-point polish needs shared samples; the resampled protocol has none.
      shared_samples = !proto.resample;
      independent_objects = proto.resample;
      if (jitter_sigma >= 0.0) {
        proto.jitter_sigma = jitter_sigma;
        proto.jitter_clip = 5.0 * jitter_sigma;
      }
      // The network sees each generated cloud whole, as in RIENet's protocol: a partial crop
      // has fewer points than the protocol's, the outlier protocol more (1024 + 200), and
      // neither is sub-sampled (set below, from the largest cloud).
      feed_whole = true;
      std::mt19937_64 rng(seed);
      for (int i = 0; i < n_pairs; ++i) {
        pairs.push_back(
            obmnet::makePair(objects[static_cast<std::size_t>(i) % objects.size()], proto, rng));
        pairs.back().name = objects[static_cast<std::size_t>(i) % objects.size()].frame_id;
      }
      double ov = 0;
      for (const auto& p : pairs) ov += p.overlap / static_cast<double>(pairs.size());
      std::ostringstream os;
      os << "protocol " << protocol << ", " << group << " group (" << objects.size()
         << " objects), " << n_pairs << " pairs, seed " << seed << ", mean overlap " << ov;
      if (jitter_sigma >= 0.0) os << ", jitter σ " << jitter_sigma;
      info = os.str();
    }
    if (feed_whole && num_points < 0) {
      std::size_t largest = 0;
      for (const auto& p : pairs) largest = std::max({largest, p.source.size(), p.target.size()});
      num_points = static_cast<int>(largest);
    }
    if (!pairs_dir.empty() && num_points < 0) {
      // Point sets of object size are fed whole, as the generated pairs are: sub-sampling each
      // cloud on its own would replace the samples two clouds share (RIENet-style pairs, where
      // the source is the target's points moved) by independent ones, which the object models
      // were not trained on. Larger clouds (sweeps, RGB-D frames) get the model's point count.
      std::size_t largest = 0;
      for (const auto& p : pairs) largest = std::max({largest, p.source.size(), p.target.size()});
      num_points = largest <= kMaxWholePoints ? static_cast<int>(largest) : 0;
    }
    if (num_points < 0) num_points = 0;  // as the model was trained
    if (unit <= 0.0) unit = 1.0;
    // obmnet::makePair draws both clouds of a generated pair from the same samples, which is
    // when the point-to-point polish helps (IcpParams); sweeps and external pairs do not.
    if (polish < 0.0) polish = shared_samples ? 0.05 : 0.0;
    // Independent samplings of an object leave pairs a few spacings apart that pull the
    // point-to-plane minimum; a kernel near the noise level at the end removes most of that
    // (IcpParams::final_kernel_scale). Measured on object pairs only, so on by default there.
    if (final_kernel < 0.0) final_kernel = independent_objects ? 0.005 : 0.0;
    if (icp_normal_neighbors <= 0) icp_normal_neighbors = 10;
    const bool coloured_pairs =
        !pairs.empty() && std::all_of(pairs.begin(), pairs.end(), [](const auto& p) {
          return p.source.hasColors() && p.target.hasColors();
        });
    // Depth frames with colour: coloured ICP by default (docs/benchmarks.md, "Coloured ICP for
    // depth frames": started at the answer, λ 0.1 kept all of 40 simulated pairs where geometric
    // ICP let 6 slide off, and from the pairs' own starts it converged as often).
    if (icp_color_weight < 0.0)
      icp_color_weight = protocol == "rgbd_frames" && coloured_pairs ? 0.1 : 0.0;
    if (icp_color_weight > 0.0) {
      if (!coloured_pairs)
        throw ConfigError("--icp-color-weight: needs pairs whose clouds all carry colours (the "
                          "rgbd_frames protocol with colour images)");
      std::ostringstream os;
      os << ", coloured ICP λ " << icp_color_weight;
      info += os.str();
    }
    // Coloured inliers with coloured ICP (docs/benchmarks.md, "Coloured inliers": on the
    // simulated frame pairs 0.05 turned slides with more geometric inliers than the right pose
    // into losses of the count; 0.1 let most of them through).
    if (color_inlier < 0.0) color_inlier = icp_color_weight > 0.0 ? 0.05 : 0.0;
    if (color_inlier > 0.0) {
      if (!(icp_color_weight > 0.0))
        throw ConfigError("--color-inlier: needs coloured ICP (--icp-color-weight > 0)");
      std::ostringstream os;
      os << ", coloured inliers within " << color_inlier;
      info += os.str();
    }
    IcpFinish finish;
    finish.polish = polish;
    finish.final_kernel = final_kernel;
    finish.weak = weak_threshold;
    finish.normal_neighbors = icp_normal_neighbors;
    finish.color_weight = icp_color_weight;
    finish.color_inlier = color_inlier;
    if (overlap_keep < 0.0) overlap_keep = 0.5;
    if (overlap_keep > 1.0) throw ConfigError("--overlap-stage must be in [0, 1]");
    // The correlative search of the search rows (registration::correlativeSearch).
    registration::CorrelativeSearchParams search;
    // Sensor frames (a camera's, a LiDAR's) turn about the sensor's vertical; objects and
    // fragments, whose pose may be any turn, over every rotation about their centroid.
    const bool sensor_frames = protocol == "rgbd_frames" || protocol == "kitti";
    search.axis = !search_axis.empty() ? search_axis
                  : protocol == "rgbd_frames" ? "y"
                  : protocol == "kitti"       ? "z"
                                              : "any";
    search.align_centroids = search.axis == "any";
    search.heading_range_deg = protocol == "rgbd_frames" ? 60.0 : protocol == "kitti" ? 180.0 : 90.0;
    search.heading_step_deg = search_step > 0.0 ? search_step : search.axis == "any" ? 7.5 : 3.0;
    search.translation_range = protocol == "rgbd_frames" ? 1.0 : protocol == "kitti" ? 20.0 : 0.3 * unit;
    // A LiDAR's sweeps differ little in height (a road's slope over tens of metres).
    if (protocol == "kitti") search.axial_range = 1.0;
    if (!search_range.empty()) {
      char tail = 0;
      double axial = -1.0;
      const int got = std::sscanf(search_range.c_str(), "%lf,%lf,%lf%c", &search.heading_range_deg,
                                  &search.translation_range, &axial, &tail);
      if (got != 2 && got != 3)
        throw ConfigError("--search-range: expected DEG,M or DEG,M,AXIAL, got '" + search_range +
                          "'");
      search.axial_range = axial;
    }
    search.cell = search_cell > 0.0     ? search_cell
                  : protocol == "kitti" ? 1.0
                  : !sensor_frames      ? 0.1 * unit
                                        : search.translation_range / 10.0;
    // Poses handed on: every rotation of an object, 32 (a turn 10° off can score below a wrong
    // one), one translation per turn; depth frames far apart, 16 (the right place can rank below
    // the eighth pose: docs/benchmarks.md, "Frame pairs far apart: more of the search's poses").
    search.candidates = search_candidates > 0  ? search_candidates
                        : protocol == "kitti" ? 8
                        : sensor_frames       ? 16
                                              : 32;
    search.shifts_per_heading = search_shifts > 0    ? search_shifts
                                : protocol == "kitti" ? 10
                                : sensor_frames       ? 3
                                                      : 1;
    // The turns of every rotation lie 7.5° apart: poses handed on 25° apart, so that they are
    // not the neighbours of one wrong maximum (ICP from one reaches its neighbours' poses).
    if (search.axis == "any") search.min_separation_deg = 25.0;
    search.sample_points = search_points > 0 ? search_points : sensor_frames ? 1000 : 300;
    // Refined starts of objects converge onto some surface; at the noise's scale (σ = 0.01 of the
    // jittered protocols) only the right one lies on it (docs/obm-bench.md).
    if (choice_plane < 0.0) choice_plane = sensor_frames ? 0.0 : 0.01;
    // LiDAR sweeps: slides along a street a block apart, and the free space to tell them apart
    // (docs/obm-bench.md, "The correlative search").
    if (free_space < 0.0) free_space = protocol == "kitti" ? 8.0 : 0.0;
    if (protocol == "kitti") search.min_separation_m = 5.0;
    search.seed = seed;
    search.color_tolerance = search_color;
    try {
      search.validate();
    } catch (const ConfigError& e) {
      throw ConfigError(std::string("--search-axis / --search-range / --search-cell: ") + e.what());
    }
    if (!start_near.empty()) {
      double deg = -1.0, m = -1.0;
      char tail = 0;
      if (std::sscanf(start_near.c_str(), "%lf,%lf%c", &deg, &m, &tail) != 2 || !(deg >= 0.0) ||
          !(deg <= 180.0) || !(m >= 0.0))
        throw ConfigError("--start-near: expected DEG,M with 0 <= DEG <= 180 and M >= 0, got '" +
                          start_near + "'");
      std::mt19937_64 rng(seed);
      for (auto& p : pairs) datasets::startNearPose(p, p.T_target_source, deg, m, rng);
      info += ", each started within " + start_near + " (deg, units) of its answer";
    }
    if (!write_pairs.empty()) bench::writePairFolder(write_pairs, pairs);

    NetRun net;
    net.model = model;
    net.threads = threads;
    net.num_points = num_points;
    net.denoise = denoise;
    net.soft_sampling = sampling == "soft" ? 1 : sampling == "hard" ? 0 : -1;
    net.iterations = iterations;
    net.spatial_sigma = spatial_sigma;
    net.yaw_hypotheses = yaw_hypotheses;
    net.free_space = free_space;
    net.free_space_hypotheses = free_space_hypotheses;
    // Depth frame pairs: a pose turned onto another wall can land the network's heaviest points
    // and leave most of the frame unpaired (docs/benchmarks.md, "Choosing among the starts of
    // frame pairs").
    if (choice_inliers < 0.0) choice_inliers = protocol == "rgbd_frames" ? 1.0 : 0.0;
    net.choice_inliers = choice_inliers;
    // LiDAR sweeps: the heading the pair is given in is kept unless another hypothesis's
    // consensus is clearly larger, and the pair as given is kept when the network's matches
    // agree on no hypothesis (docs/benchmarks.md, "The start's heading and a consensus floor").
    if (start_heading_margin < 0.0) start_heading_margin = protocol == "kitti" ? 1.25 : 1.0;
    if (min_consensus < 0.0) min_consensus = protocol == "kitti" ? 0.06 : 0.0;
    net.start_heading_margin = start_heading_margin;
    net.min_consensus = min_consensus;
    // Depth frames are in the camera's optical frame (z forward), in metres.
    if (protocol == "rgbd_frames") net.free_space_params = registration::FreeSpaceParams::depthCamera();
    if (const std::string why = registration::startTurnAxesError(start_turn_axes); !why.empty())
      throw ConfigError("--start-turn-axes: " + why);
    std::vector<bench::Method> methods;
    if (!ablation.empty()) {
      for (const auto& m : splitList(ablation)) {
        NetRun row = net;
        row.model = m;
        methods.push_back(obmnetMethod(m, row));
      }
    } else {
      methods.push_back(obmnetMethod("obmnet", net));
      // The network refined as the self-training teacher labels a pair (point-to-plane ICP on
      // its own normalised points, from its pose and from the identity; docs/training.md); on
      // request (--methods).
      if (!methods_arg.empty()) {
        NetRun net_t = net;
        net_t.teacher_refine = true;
        methods.push_back(obmnetMethod("obmnet+teacher", net_t));
      }
      // The network verified against its start (the identity of the pair as given): meaningful
      // where the start is a prior (consecutive sweeps), so listed by default for the kitti
      // protocol and on request elsewhere.
      if (protocol == "kitti" || !methods_arg.empty())
        methods.push_back(obmnetMethod("obmnet+verify", net, true));
      // Not moving at all: the pose the pair is given in, the baseline a network alone must beat
      // where the start is a prior (consecutive sweeps and frames; on request).
      if (!methods_arg.empty())
        methods.push_back({"identity", [](const PointCloud&, const PointCloud&) {
                             return bench::MethodResult(Isometry3d::Identity());
                           }});
      // One matcher of each kind (one model load), shared by the rows that use it.
      const auto net_icp = obmnetIcpMatcher(net, unit, finish, overlap_keep);
      const auto icp = objectIcpMatcher(unit, finish);
      methods.push_back(matcherMethod("obmnet+icp", net_icp));
      methods.push_back(matcherMethod("icp", icp));
      // The refinement of `obmnet+icp` started at the ground truth: where it leaves the answer,
      // the ceiling of every refined row (a diagnostic; on request).
      if (!methods_arg.empty()) {
        bench::Method at_truth =
            matcherMethod("icp@truth", objectRefineIcpMatcher(unit, finish));
        at_truth.start_at_truth = true;
        methods.push_back(at_truth);
        // The network alone started at the ground truth: how far its own pass moves off the
        // answer (its floor; with a spatial prior it corrects, so it should stay).
        bench::Method net_at_truth = obmnetMethod("obmnet@truth", net);
        net_at_truth.start_at_truth = true;
        methods.push_back(net_at_truth);
      }
      // More starts for 6-DoF pairs (--start-turns): the matcher's own, chosen by its
      // confidence, and the same starts for ICP, chosen by its inlier ratio.
      if (start_turns > 0.0) {
        NetRun net_t = net;
        net_t.start_turn_deg = start_turns;
        net_t.start_turn_axes = start_turn_axes;
        methods.push_back(matcherMethod("obmnet+icp-turns",
                                        obmnetIcpMatcher(net_t, unit, finish, overlap_keep)));
        methods.push_back(icpTurnsMethod(icp, start_turns, start_turn_axes));
      }
      // Every yaw hypothesis of the network refined by ICP, and its classical counterpart (the
      // same headings tried blindly): for sweeps without a heading prior (loops).
      if (protocol == "kitti" || !methods_arg.empty()) {
        methods.push_back(
            matcherMethod("obmnet+icp-all", obmnetIcpMatcher(net, unit, finish, overlap_keep, 0)));
        methods.push_back(icpYawMethod(icp, 4));
        methods.push_back(matcherMethod("obmnet+icp-all+yaw4",
                                        obmnetIcpMatcher(net, unit, finish, overlap_keep, 0, 4)));
      }
      // The competition with the identity start helps only where the identity is a meaningful
      // prior (consecutive sweeps in their sensor frames); on pairs with a random rotation the
      // identity's ICP often pairs more points in a wrong pose (docs/obm-bench.md), so it is
      // listed by default for the kitti protocol and on request (--methods) elsewhere.
      if (protocol == "kitti" || !methods_arg.empty())
        methods.push_back(obmnetIcpOrIcpMethod(net_icp, icp));
      // The network's correspondences given to RANSAC beside its weighted SVD
      // (ObmNetRegistrar::Options::ransac_iterations); on request (--methods).
      // The `ransac` rows rank the yaw hypotheses by their fitness, the `consensus` rows by their
      // consensus share (ObmNetRegistrar::Options::select_by_consensus).
      if (!methods_arg.empty() && ransac > 0) {
        for (const bool by_consensus : {false, true}) {
          NetRun net_r = net;
          net_r.ransac = ransac;
          net_r.by_consensus = by_consensus;
          const std::string row = by_consensus ? "obmnet+consensus" : "obmnet+ransac";
          methods.push_back(obmnetMethod(row, net_r));
          methods.push_back(
              matcherMethod(row + "+icp", obmnetIcpMatcher(net_r, unit, finish, overlap_keep)));
          methods.push_back(matcherMethod(
              row + "+icp-all+yaw4", obmnetIcpMatcher(net_r, unit, finish, overlap_keep, 0, 4)));
        }
      }
      // The correlative search over heading and translation (a classical global start, on
      // request): its best pose alone, the refinement from each of its poses, and the matcher
      // with the search's poses as more starts (ObmNetMatcherParams::search_candidates).
      if (!methods_arg.empty()) {
        methods.push_back({"search", [search](const PointCloud& s, const PointCloud& t) {
                             const auto poses = searchPoses(s, t, search);
                             return bench::MethodResult(poses.empty() ? Isometry3d::Identity()
                                                                      : poses.front());
                           }});
        // The classical chain chooses by its inliers within the same distance of the planes.
        auto choice_confidence = objectConfidenceParams(unit, finish);
        if (choice_plane > 0.0) choice_confidence.inlier_threshold = choice_plane * unit;
        methods.push_back(searchIcpMethod(
            std::make_shared<registration::IcpMatcher>(objectRefineIcpParams(unit, finish),
                                                       choice_confidence),
            search, free_space, net.free_space_params));
        registration::ObmNetMatcherParams with_search =
            obmnetIcpParams(net, unit, finish, overlap_keep);
        with_search.search = search;
        with_search.search_candidates = search.candidates;
        with_search.choice_plane_distance = choice_plane * unit;
        methods.push_back(
            matcherMethod("obmnet+icp+search", obmnetIcpMatcher(with_search, unit, finish)));
      }
      bench::Open3dParams o3d_params = scaledOpen3dParams(unit);
      o3d_params.colored = coloured_pairs;
      auto o3d = bench::open3dMethods(o3d_params);
      for (const auto& m : o3d) methods.push_back(m);
      // With --start-turns and Open3D: FGR's pose as one more start of the network.
      if (start_turns > 0.0)
        for (const auto& m : o3d)
          if (m.name == "o3d_fgr") {
            NetRun net_t = net;
            net_t.start_turn_deg = start_turns;
            net_t.start_turn_axes = start_turn_axes;
            // From FGR's pose: the network's pass and its ICP, and ICP from the pose itself (one
            // "heading", from the refinement's narrow gate, no margin), the one with more inliers
            // kept. The network's pass moves some right starts away (docs/benchmarks.md, "A
            // global start for frame pairs").
            registration::ObmNetMatcherParams at_fgr =
                obmnetIcpParams(net, unit, finish, overlap_keep, 1, 1, true);
            at_fgr.init_headings_gate = 0.0;
            at_fgr.init_headings_margin = 1.0;
            const auto from_fgr = obmnetIcpMatcher(at_fgr, unit, finish);
            methods.push_back(globalStartMethod(
                "obmnet+icp-turns+fgr", obmnetIcpMatcher(net_t, unit, finish, overlap_keep),
                from_fgr, m, net.choice_inliers));
            methods.push_back(
                globalStartMethod("obmnet+icp@fgr", nullptr, from_fgr, m, net.choice_inliers));
            // The correlative search's poses as more starts of the matcher, beside its turns
            // and FGR's pose (on request).
            if (!methods_arg.empty()) {
              registration::ObmNetMatcherParams turns_search =
                  obmnetIcpParams(net_t, unit, finish, overlap_keep);
              turns_search.search = search;
              turns_search.search_candidates = search.candidates;
              turns_search.choice_plane_distance = choice_plane * unit;
              methods.push_back(globalStartMethod("obmnet+icp-turns+fgr+search",
                                                  obmnetIcpMatcher(turns_search, unit, finish),
                                                  from_fgr, m, net.choice_inliers));
            }
            // The classical chain with the project's refinement after FGR (the ICP after the
            // network, its narrow gate: from the `icp` row's 0.5-unit gate good FGR poses slid
            // off, docs/benchmarks.md, "A global start for frame pairs"): what the network's
            // pass adds to the same start and the same refinement.
            const auto refine = objectRefineIcpMatcher(unit, finish);
            methods.push_back({"o3d_fgr+obm_icp", [refine, m](const PointCloud& s,
                                                              const PointCloud& t) {
                                 return matchResult(
                                     refine->match(s, t, m.fn(s, t).T_target_source));
                               }});
          }
      // The module as a plug-in of the methods users have (the paper's Table 4); listed on
      // request (--methods), as they cost a network pass (two for the feature peers).
      if (!methods_arg.empty()) {
        methods.push_back(
            matcherMethod("obmm+icp", obmmIcpMatcher(model, threads, num_points, unit, finish)));
        registration::ObmNetMatcherParams pp;
        pp.model_path = model;
        pp.num_points = num_points;
        pp.threads = threads;
        const auto pred = std::make_shared<const registration::OverlapPredictor>(pp);
        const double keep = overlap_keep > 0.0 ? overlap_keep : 0.5;
        for (const auto& m : o3d) {
          if (m.name == "o3d_fgr") methods.push_back(overlapRestricted("obmm+fgr", pred, m, keep));
          if (m.name == "o3d_ransac")
            methods.push_back(overlapRestricted("obmm+ransac", pred, m, keep));
        }
      }
    }
    if (!methods_arg.empty()) {
      const auto keep = splitList(methods_arg);
      std::vector<bench::Method> sel;
      for (const auto& name : keep) {
        auto it = std::find_if(methods.begin(), methods.end(),
                               [&](const auto& m) { return m.name == name; });
        if (it == methods.end())
          throw ConfigError("--methods: unknown or unavailable method '" + name + "'");
        sel.push_back(*it);
      }
      methods = sel;
    }
    // LiDAR sweeps and depth frames (each in its sensor's frame): every method's pose is also
    // scored by its free-space agreement, 1 − r (docs/registration.md, "Free space"), a
    // confidence that any method can have; computed outside the methods' timed calls.
    bench::PoseScorer free_space_score;
    if (protocol == "kitti" || protocol == "rgbd_frames")
      free_space_score = [fsp = net.free_space_params](const PointCloud& s, const PointCloud& t,
                                                       const Isometry3d& T) {
        const registration::FreeSpaceCheck check(s.points, t.points, fsp);
        return std::vector<std::pair<std::string, double>>{
            {"free_space", 1.0 - check.conflicts(T).ratio()}};
      };
    const eval::RecallThresholds recall{recall_deg, recall_trans};
    auto scores = bench::runBenchmark(pairs, methods, recall, !quiet, free_space_score);
    std::ostringstream title;
    title << info << "; recall: RRE < " << recall_deg << "° and RTE < " << recall_trans;
    const auto ratings = bench::rateConfidences(scores, recall);
    std::string md = bench::markdownTable(scores, title.str());
    const bool by_surface = surface_error > 0.0 && !scorer_of_pair.empty();
    if (by_surface) {
      bench::scoreSurfaces(pairs, scorer_of_pair, scores);
      md += "\nUp to the objects' symmetries (surface error: mean distance of the object placed "
            "by the estimate from the object placed by the truth; docs/metrics.md):\n\n" +
            bench::surfaceTable(scores, recall, surface_error);
    }
    if (!ratings.empty())
      md += "\nConfidence scores as detectors of a correct registration (AUROC; 1 = perfect, "
            "0.5 = chance):\n\n" +
            bench::confidenceTable(ratings);
    std::cout << md;
    if (!md_out.empty()) writeTextAtomically(md_out, md);
    if (!json_out.empty())
      writeTextAtomically(json_out, bench::jsonReport(pairs.size(), scores, recall, info, ratings,
                                                      by_surface ? surface_error : 0.0));
    if (!per_pair_out.empty())
      writeTextAtomically(per_pair_out, bench::perPairCsv(pairs, scores, recall));
    return 0;
  });
}
