#include "obm/bench/methods.hpp"

#include <algorithm>
#include <cmath>
#include <map>
#include <memory>
#include <numeric>
#include <optional>
#include <sstream>
#include <utility>

#include "obm/config/config_node.hpp"
#include "obm/core/errors.hpp"
#include "obm/registration/correlative_search.hpp"
#include "obm/registration/free_space.hpp"
#include "obm/registration/icp.hpp"
#include "obm/registration/obmnet_matcher.hpp"
#ifdef OBM_BENCH_HAS_OBMNET
#include "obm/obmnet/config.hpp"
#include "obm/obmnet/registrar.hpp"
#include "obm/registration/obmnet_options.hpp"
#else
namespace obm::obmnet {
struct TeacherParams {};
}  // namespace obm::obmnet
#endif

namespace obm::bench {
namespace reg = registration;

namespace {

struct RowName {
  Row row;
  const char* name;
};
constexpr RowName kRows[] = {
    {Row::Obmnet, "obmnet"},
    {Row::ObmnetVerify, "obmnet+verify"},
    {Row::ObmnetTeacher, "obmnet+teacher"},
    {Row::ObmnetRansac, "obmnet+ransac"},
    {Row::ObmnetConsensus, "obmnet+consensus"},
    {Row::ObmnetAtTruth, "obmnet@truth"},
    {Row::Identity, "identity"},
    {Row::ObmnetIcp, "obmnet+icp"},
    {Row::ObmnetIcpAll, "obmnet+icp-all"},
    {Row::ObmnetIcpAllYaw4, "obmnet+icp-all+yaw4"},
    {Row::ObmnetRansacIcp, "obmnet+ransac+icp"},
    {Row::ObmnetRansacIcpAllYaw4, "obmnet+ransac+icp-all+yaw4"},
    {Row::ObmnetConsensusIcp, "obmnet+consensus+icp"},
    {Row::ObmnetConsensusIcpAllYaw4, "obmnet+consensus+icp-all+yaw4"},
    {Row::ObmnetIcpSearch, "obmnet+icp+search"},
    {Row::ObmnetIcpOrIcp, "obmnet+icp|icp"},
    {Row::ObmnetIcpTurns, "obmnet+icp-turns"},
    {Row::Icp, "icp"},
    {Row::IcpAtTruth, "icp@truth"},
    {Row::IcpYaw4, "icp-yaw4"},
    {Row::IcpTurns, "icp-turns"},
    {Row::Search, "search"},
    {Row::SearchIcp, "search+icp"},
    {Row::ObmmIcp, "obmm+icp"},
    {Row::ObmmFgr, "obmm+fgr"},
    {Row::ObmmRansac, "obmm+ransac"},
    {Row::ObmnetIcpTurnsFgr, "obmnet+icp-turns+fgr"},
    {Row::ObmnetIcpAtFgr, "obmnet+icp@fgr"},
    {Row::ObmnetIcpTurnsFgrSearch, "obmnet+icp-turns+fgr+search"},
    {Row::O3dFgrObmIcp, "o3d_fgr+obm_icp"},
};

}  // namespace

RowRequest parseRow(const std::string& name, const std::string& where) {
  for (const auto& r : kRows)
    if (name == r.name) return {r.row, name};
  for (const auto& o : open3dMethodNames())
    if (name == o) return {Row::Open3d, name};
  std::string names;
  for (const auto& r : kRows) names += (names.empty() ? "" : ", ") + std::string(r.name);
  for (const auto& o : open3dMethodNames()) names += ", " + o;
  throw ConfigError(where + ": unknown method '" + name + "' (" + names + ")");
}

std::string rowName(Row row) {
  for (const auto& r : kRows)
    if (r.row == row) return r.name;
  return "open3d";
}

std::vector<RowRequest> expandRows(const std::vector<std::string>& names, const std::string& where,
                                   bool coloured) {
  std::vector<RowRequest> out;
  for (const auto& n : names) {
    if (n == "open3d") {
      Open3dParams p;
      p.colored = coloured;
      for (const auto& m : open3dMethods(p)) out.push_back({Row::Open3d, m.name});
    } else {
      out.push_back(parseRow(n, where));
    }
  }
  return out;
}

namespace {

/// A matcher's pose with its confidence scores: ICP's own fitness and inlier ratio, and for the
/// OBMNet matchers the bias-weighted confidence (MatchResult::network_confidence).
MethodResult matchResult(const reg::MatchResult& r) {
  MethodResult out(r.T_target_source);
  out.scores = {{"fitness", r.fitness}, {"inlier_ratio", r.inlier_ratio}};
  if (r.alpha != 1.0 || r.network_confidence >= 0.0)
    out.scores.push_back({"obm_confidence", std::max(0.0, r.network_confidence)});
  return out;
}

/// A row that runs `matcher` from the identity.
Method matcherMethod(std::string name, std::shared_ptr<const reg::ScanMatcher> matcher) {
  return {std::move(name), [matcher](const PointCloud& s, const PointCloud& t) {
            return matchResult(matcher->match(s, t, Isometry3d::Identity()));
          }};
}

/// The network alone (its registrar, as ObmNetMatcher runs it): the pose and the network's own
/// scores. With hypothesis_free_space_weight the yaw hypotheses are re-ranked as the matcher
/// ranks them (the registrar's score discounted by the free-space conflicts).
Method registrarMethod(std::string name, const reg::ObmNetMatcherParams& p, bool keep_start,
                       const obmnet::TeacherParams* teacher) {
#ifndef OBM_BENCH_HAS_OBMNET
  throw ConfigError(name + ": this build has no OBMNet (LibTorch); the classical rows run without it");
#else
  obmnet::ObmNetRegistrar::Options o = reg::registrarOptions(p, true);
  o.keep_start_if_fitter = keep_start;
  if (teacher) {
    o.teacher_refine = true;
    o.teacher = *teacher;
  }
  auto registrar = std::make_shared<obmnet::ObmNetRegistrar>(o);
  const double weight = p.hypothesis_free_space_weight;
  const reg::FreeSpaceParams fsp = p.free_space;
  return {std::move(name), [registrar, weight, fsp](const PointCloud& s, const PointCloud& t) {
            const obmnet::RegistrationResult r = registrar->align(s, t);
            MethodResult out(r.T_target_source);
            out.scores = {{"keypoint_fitness", r.fitness}, {"overlap", r.overlap}};
            std::size_t k = 0;  // the returned hypothesis
            if (weight > 0.0 && r.hypotheses.size() > 1 && !r.kept_start) {
              std::vector<Isometry3d> poses;
              std::vector<double> ranks;
              for (const auto& h : r.hypotheses) {
                poses.push_back(h.T_target_source);
                ranks.push_back(h.score);
              }
              const reg::FreeSpaceCheck check(s.points, t.points, fsp);
              k = reg::chooseByFreeSpace(poses, ranks, check, weight);
              out.T_target_source = poses[k];
              out.scores = {{"keypoint_fitness", r.hypotheses[k].fitness},
                            {"overlap", r.hypotheses[k].overlap}};
            }
            // With RANSAC: the share of source points in the returned hypothesis's consensus.
            if (!r.hypotheses.empty() && r.hypotheses[k].consensus >= 0.0)
              out.scores.push_back({"consensus", r.hypotheses[k].consensus});
            return out;
          }};
#endif
}

/// ICP from each of `starts` against one prepared target, keeping the result with the largest
/// inlier ratio (ICP's own score; the network's rows use their confidence), discounted by the
/// pose's free-space conflicts when `free_space` > 0 as the matcher's choice is
/// (ObmNetMatcherParams::choice_free_space_weight).
MethodResult bestIcpOfStarts(const reg::ScanMatcher& icp, const PointCloud& s, const PointCloud& t,
                             const std::vector<Isometry3d>& starts, double free_space = 0.0,
                             const reg::FreeSpaceParams& free_space_params = {}) {
  std::optional<reg::MatchResult> best;
  double best_score = -1.0;
  const reg::PreparedTarget target = icp.prepare(t);  // once for all starts
  std::optional<reg::FreeSpaceCheck> check;
  if (free_space > 0.0) check.emplace(s.points, t.points, free_space_params);
  for (const Isometry3d& T0 : starts) {
    reg::MatchResult r = icp.match(s, target, T0);
    if (r.status == reg::MatchStatus::TooFewCorrespondences) continue;
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

/// The correlative search's poses, best first.
std::vector<Isometry3d> searchPoses(const PointCloud& s, const PointCloud& t,
                                    const reg::CorrelativeSearchParams& p) {
  std::vector<Isometry3d> out;
  for (const auto& h : reg::correlativeSearch(s, t, p)) out.push_back(h.T_target_source);
  return out;
}

/// A global start for the network: the network + ICP from its own starts (`turns`, from the
/// identity) and from a global method's pose (`from_start` sees the source moved by it), keeping
/// the result with the higher bias-weighted confidence times the inlier share to the power
/// `choice_inliers` (as the matcher's own starts compete). Without `turns`: from the pose alone.
Method globalStartMethod(std::string name, std::shared_ptr<const reg::ScanMatcher> turns,
                         std::shared_ptr<const reg::ScanMatcher> from_start, Method global,
                         double choice_inliers) {
  return {std::move(name), [turns, from_start, global, choice_inliers](const PointCloud& s,
                                                                       const PointCloud& t) {
            const Isometry3d T_global = global.fn(s, t).T_target_source;
            reg::MatchResult b = from_start->match(s, t, T_global);
            if (!turns) return matchResult(b);
            reg::MatchResult a = turns->match(s, t, Isometry3d::Identity());
            auto score = [choice_inliers](const reg::MatchResult& r) {
              return reg::startChoiceScore(r.network_confidence, r.inlier_ratio, choice_inliers);
            };
            const bool take_b = b.status != reg::MatchStatus::TooFewCorrespondences &&
                                b.status != reg::MatchStatus::TooFewPoints && score(b) > score(a);
            return matchResult(take_b ? b : a);
          }};
}

/// `obmm+<peer>`: the peer on the points the module predicts in the overlap only — the fraction
/// `keep` of each cloud's network points with the largest ω.
Method overlapRestricted(std::string name, std::shared_ptr<const reg::OverlapPredictor> pred,
                         Method peer, double keep) {
  return {std::move(name), [pred, peer, keep](const PointCloud& s, const PointCloud& t) {
            const reg::OverlapPrediction o = pred->predict(s, t);
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

/// Builds the rows of one run, each matcher once.
class Registry {
 public:
  Registry(const Preset& preset, const RunOptions& run) : preset_(preset), run_(run) {
    const auto& m = preset.matcher;
    refine_icp_ = m.icp;
    confidence_ = m.confidence;
    // The classical rows start as blind headings do: from their (wide) gate, the network's
    // poses from the refinement's narrow one.
    wide_icp_ = m.icp;
    if (m.obmnet.init_headings_gate > 0.0)
      wide_icp_.initial_max_correspondence_distance = m.obmnet.init_headings_gate;
    base_ = m.obmnet;
    base_.search.seed = run.seed;
    // The rows without the search in their name run the matcher without it; only the search
    // rows choose among its poses on the planes.
    base_.search_candidates = 0;
    base_.choice_plane_distance = 0.0;
    open3d_params_.voxel *= preset.bench.open3d_unit;
    open3d_params_.normal_radius *= preset.bench.open3d_unit;
    open3d_params_.feature_radius *= preset.bench.open3d_unit;
    open3d_params_.icp_max_distance *= preset.bench.open3d_unit;
    open3d_params_.ransac_max_distance *= preset.bench.open3d_unit;
    open3d_params_.colored = run.coloured;
    open3d_ = open3dMethods(open3d_params_);
  }

  Method build(const RowRequest& r) {
    const auto& P = preset_.matcher.obmnet;
    const double turns = preset_.bench.start_turn_deg;
    switch (r.row) {
      case Row::Obmnet:
        return registrarMethod(r.name, base_, false, nullptr);
      case Row::ObmnetVerify:
        return registrarMethod(r.name, base_, true, nullptr);
      case Row::ObmnetTeacher: {
        if (run_.teacher_config.empty())
          throw ConfigError("obmnet+teacher: no teacher config given");
#ifdef OBM_BENCH_HAS_OBMNET
        const obmnet::TeacherParams teacher = obmnet::TeacherParams::load(
            ConfigNode::loadFile(run_.teacher_config).child("train").child("teacher"));
#else
        const obmnet::TeacherParams teacher;
#endif
        return registrarMethod(r.name, base_, false, &teacher);
      }
      case Row::ObmnetRansac:
        return registrarMethod(r.name, ransacParams(false), false, nullptr);
      case Row::ObmnetConsensus:
        return registrarMethod(r.name, ransacParams(true), false, nullptr);
      case Row::ObmnetAtTruth: {
        Method m = registrarMethod(r.name, base_, false, nullptr);
        m.start_at_truth = true;
        return m;
      }
      case Row::Identity:
        return {r.name, [](const PointCloud&, const PointCloud&) {
                  return MethodResult(Isometry3d::Identity());
                }};
      case Row::ObmnetIcp:
        return matcherMethod(r.name, netIcp(base_, "base"));
      case Row::ObmnetIcpAll:
        return matcherMethod(r.name, netIcp(allHypotheses(base_, 0)));
      case Row::ObmnetIcpAllYaw4:
        return matcherMethod(r.name, netIcp(allHypotheses(base_, 4)));
      case Row::ObmnetRansacIcp:
        return matcherMethod(r.name, netIcp(ransacParams(false)));
      case Row::ObmnetRansacIcpAllYaw4:
        return matcherMethod(r.name, netIcp(allHypotheses(ransacParams(false), 4)));
      case Row::ObmnetConsensusIcp:
        return matcherMethod(r.name, netIcp(ransacParams(true)));
      case Row::ObmnetConsensusIcpAllYaw4:
        return matcherMethod(r.name, netIcp(allHypotheses(ransacParams(true), 4)));
      case Row::ObmnetIcpSearch:
        return matcherMethod(r.name, netIcp(withSearch(base_)));
      case Row::ObmnetIcpOrIcp: {
        auto net = netIcp(base_, "base");
        auto icp = wideIcp();
        return {r.name, [net, icp](const PointCloud& s, const PointCloud& t) {
                  const reg::MatchResult a = net->match(s, t, Isometry3d::Identity());
                  const reg::MatchResult b = icp->match(s, t, Isometry3d::Identity());
                  auto paired = [](const reg::MatchResult& x) {
                    return x.status != reg::MatchStatus::TooFewCorrespondences &&
                           x.status != reg::MatchStatus::EmptyInput &&
                           x.status != reg::MatchStatus::TooFewPoints;
                  };
                  const bool take_b =
                      paired(b) && (!paired(a) || b.num_correspondences > a.num_correspondences);
                  return matchResult(take_b ? b : a);
                }};
      }
      case Row::ObmnetIcpTurns:
        return matcherMethod(r.name, netIcp(withTurns(base_, r.name)));
      case Row::Icp:
        return matcherMethod(r.name, wideIcp());
      case Row::IcpAtTruth: {
        Method m = matcherMethod(r.name, refineIcp());
        m.start_at_truth = true;
        return m;
      }
      case Row::IcpYaw4: {
        auto icp = wideIcp();
        return {r.name, [icp](const PointCloud& s, const PointCloud& t) {
                  std::vector<Isometry3d> starts;
                  for (int h = 0; h < 4; ++h)
                    starts.push_back(makeIsometry(
                        Eigen::AngleAxisd(2.0 * 3.14159265358979323846 * h / 4.0,
                                          Eigen::Vector3d::UnitZ())
                            .toRotationMatrix(),
                        Eigen::Vector3d::Zero()));
                  return bestIcpOfStarts(*icp, s, t, starts);
                }};
      }
      case Row::IcpTurns: {
        withTurns(base_, r.name);  // checks that the preset has turns
        auto icp = wideIcp();
        const std::string axes = P.start_turn_axes;
        return {r.name, [icp, turns, axes](const PointCloud& s, const PointCloud& t) {
                  std::vector<Isometry3d> starts{Isometry3d::Identity()};
                  for (const Isometry3d& turn : reg::startTurns(turns, axes)) starts.push_back(turn);
                  return bestIcpOfStarts(*icp, s, t, starts);
                }};
      }
      case Row::Search: {
        const reg::CorrelativeSearchParams search = withSearch(base_).search;
        return {r.name, [search](const PointCloud& s, const PointCloud& t) {
                  const auto poses = searchPoses(s, t, search);
                  return MethodResult(poses.empty() ? Isometry3d::Identity() : poses.front());
                }};
      }
      case Row::SearchIcp: {
        // The classical chain chooses by its inliers within the same distance of the planes.
        const reg::ObmNetMatcherParams p = withSearch(base_);
        reg::ConfidenceParams c = confidence_;
        if (p.choice_plane_distance > 0.0) c.inlier_threshold = p.choice_plane_distance;
        auto icp = std::make_shared<reg::IcpMatcher>(refine_icp_, c);
        const reg::CorrelativeSearchParams search = p.search;
        const double fs = p.choice_free_space_weight;
        const reg::FreeSpaceParams fsp = p.free_space;
        return {r.name, [icp, search, fs, fsp](const PointCloud& s, const PointCloud& t) {
                  return bestIcpOfStarts(*icp, s, t, searchPoses(s, t, search), fs, fsp);
                }};
      }
      case Row::ObmmIcp:
        return matcherMethod(
            r.name, std::make_shared<reg::ObmmIcpMatcher>(moduleParams(), wide_icp_, confidence_));
      case Row::ObmmFgr:
      case Row::ObmmRansac: {
        const Method peer = open3d(r.row == Row::ObmmFgr ? "o3d_fgr" : "o3d_ransac", r.name);
        auto pred = std::make_shared<const reg::OverlapPredictor>(moduleParams());
        const double keep = P.overlap_stage_keep > 0.0 ? P.overlap_stage_keep : 0.5;
        return overlapRestricted(r.name, pred, peer, keep);
      }
      case Row::ObmnetIcpTurnsFgr:
        return globalStartMethod(r.name, netIcp(withTurns(base_, r.name)), fromFgr(),
                                 open3d("o3d_fgr", r.name), base_.choice_inlier_power);
      case Row::ObmnetIcpAtFgr:
        withTurns(base_, r.name);
        return globalStartMethod(r.name, nullptr, fromFgr(), open3d("o3d_fgr", r.name),
                                 base_.choice_inlier_power);
      case Row::ObmnetIcpTurnsFgrSearch:
        return globalStartMethod(r.name, netIcp(withSearch(withTurns(base_, r.name))), fromFgr(),
                                 open3d("o3d_fgr", r.name), base_.choice_inlier_power);
      case Row::O3dFgrObmIcp: {
        withTurns(base_, r.name);
        auto refine = refineIcp();
        const Method fgr = open3d("o3d_fgr", r.name);
        return {r.name, [refine, fgr](const PointCloud& s, const PointCloud& t) {
                  return matchResult(refine->match(s, t, fgr.fn(s, t).T_target_source));
                }};
      }
      case Row::Open3d:
        return open3d(r.name, r.name);
    }
    throw ContractError("buildMethods: invalid row");
  }

 private:
  /// The network's correspondences given to RANSAC; hypotheses ranked by their consensus
  /// (`by_consensus`, the +consensus rows) or by their fitness (the +ransac rows).
  reg::ObmNetMatcherParams ransacParams(bool by_consensus) const {
    reg::ObmNetMatcherParams p = base_;
    p.network.ransac_iterations = preset_.bench.ransac_iterations;
    p.network.select_by_consensus = by_consensus;
    return p;
  }
  /// Every yaw hypothesis refined, and ICP from `headings` blind headings too.
  static reg::ObmNetMatcherParams allHypotheses(reg::ObmNetMatcherParams p, int headings) {
    p.refine_hypotheses = 0;
    p.init_headings = headings;
    return p;
  }
  reg::ObmNetMatcherParams withSearch(reg::ObmNetMatcherParams p) const {
    const auto& P = preset_.matcher.obmnet;
    if (P.search_candidates < 1)
      throw ConfigError(preset_.file + ": the search rows need matcher.obmnet.search_candidates > 0");
    p.search_candidates = P.search_candidates;
    p.search.candidates = P.search_candidates;
    p.choice_plane_distance = P.choice_plane_distance;
    return p;
  }
  reg::ObmNetMatcherParams withTurns(reg::ObmNetMatcherParams p, const std::string& row) const {
    if (!(preset_.bench.start_turn_deg > 0.0))
      throw ConfigError(row + ": needs start turns (--set benchmark.start_turn_deg=DEG)");
    p.start_turn_deg = preset_.bench.start_turn_deg;
    return p;
  }
  /// From FGR's pose: the network's pass and its ICP, and ICP from the pose itself (one
  /// "heading", from the refinement's narrow gate, no margin), the one with more inliers kept.
  std::shared_ptr<const reg::ScanMatcher> fromFgr() {
    reg::ObmNetMatcherParams p = allHypotheses(base_, 1);
    p.refine_hypotheses = 1;
    p.pre_align = true;
    p.init_headings_gate = 0.0;
    p.init_headings_margin = 1.0;
    return netIcp(p, "fgr");
  }
  /// The module as a plug-in: the model and its sampling only.
  reg::ObmNetMatcherParams moduleParams() const {
    reg::ObmNetMatcherParams p;
    p.network.model_path = base_.network.model_path;
    p.network.num_points = base_.network.num_points;
    p.network.threads = base_.network.threads;
    p.pre_align = false;
    return p;
  }
  /// A matcher of its own for each row (the network's sampling noise is drawn per matcher),
  /// except the rows that compare starts of the same matcher: obmnet+icp and obmnet+icp|icp share
  /// the base one (`shared` = "base"), the FGR-start rows theirs ("fgr").
  std::shared_ptr<const reg::ScanMatcher> netIcp(const reg::ObmNetMatcherParams& p,
                                                 const std::string& shared = {}) {
    if (!shared.empty()) {
      auto it = net_icp_.find(shared);
      if (it != net_icp_.end()) return it->second;
    }
    auto m = std::make_shared<reg::ObmNetIcpMatcher>(p, refine_icp_, confidence_);
    if (!shared.empty()) net_icp_.emplace(shared, m);
    return m;
  }
  std::shared_ptr<const reg::ScanMatcher> wideIcp() {
    if (!wide_) wide_ = std::make_shared<reg::IcpMatcher>(wide_icp_, confidence_);
    return wide_;
  }
  std::shared_ptr<const reg::ScanMatcher> refineIcp() const {
    return std::make_shared<reg::IcpMatcher>(refine_icp_, confidence_);
  }
  Method open3d(const std::string& peer, const std::string& row) const {
    for (const auto& m : open3d_)
      if (m.name == peer) return m;
    throw ConfigError(row + ": needs Open3D's " + peer + " (this build has " +
                      (haveOpen3d() ? "no such peer for these pairs" : "no Open3D") + ")");
  }
  const Preset& preset_;
  RunOptions run_;
  reg::IcpParams refine_icp_, wide_icp_;
  reg::ConfidenceParams confidence_;
  reg::ObmNetMatcherParams base_;
  Open3dParams open3d_params_;
  std::vector<Method> open3d_;
  std::map<std::string, std::shared_ptr<const reg::ScanMatcher>> net_icp_;
  std::shared_ptr<const reg::ScanMatcher> wide_;
};

}  // namespace

std::vector<Method> buildMethods(const Preset& preset, const std::vector<RowRequest>& rows,
                                 const RunOptions& run) {
  Registry registry(preset, run);
  std::vector<Method> out;
  for (const auto& r : rows) out.push_back(registry.build(r));
  return out;
}

std::vector<Method> ablationMethods(const Preset& preset, const std::vector<std::string>& models) {
  std::vector<Method> out;
  for (const auto& model : models) {
    reg::ObmNetMatcherParams p = preset.matcher.obmnet;
    p.network.model_path = model;
    out.push_back(registrarMethod(model, p, false, nullptr));
  }
  return out;
}

}  // namespace obm::bench
