// OBMNet-based matchers. Compiled with OBM_REGISTRATION_HAS_OBMNET when libs/obmnet is built
// (LibTorch found); otherwise the constructors throw ConfigError. Only the torch-free inference
// header obm/obmnet/registrar.hpp is used here.
#include "obm/registration/obmnet_matcher.hpp"

#include <algorithm>
#include <cmath>
#include <numeric>
#include <optional>
#include <string>

#include "obm/core/errors.hpp"
#include "obm/core/log.hpp"
#include "obm/registration/confidence.hpp"
#include "obm/registration/icp.hpp"

#ifdef OBM_REGISTRATION_HAS_OBMNET
#include "obm/obmnet/registrar.hpp"
#include "obm/registration/obmnet_options.hpp"
#endif

namespace obm::registration {

#ifdef OBM_REGISTRATION_HAS_OBMNET

obmnet::ObmNetRegistrar::Options registrarOptions(const ObmNetMatcherParams& p, bool network_alone) {
  obmnet::ObmNetRegistrar::Options o = p.network;
  if (o.model_path.empty()) throw ConfigError("obmnet matcher: model_path is empty");
  if (o.num_points < 0) throw ConfigError("obmnet matcher: num_points must be >= 0");
  if (o.threads < 1) throw ConfigError("obmnet matcher: threads must be >= 1");
  if (!network_alone) o.min_consensus = 0.0;
  return o;
}

namespace {

obmnet::ObmNetRegistrar makeRegistrar(const ObmNetMatcherParams& p, bool network_alone = false) {
  return obmnet::ObmNetRegistrar(registrarOptions(p, network_alone));
}

/// The network stage shared by both matchers.
struct NetworkStage {
  bool ok = false;
  std::string message;
  Isometry3d T_target_source = Isometry3d::Identity();  ///< network pose (composed with T_init)
  double alpha = 1.0, overlap = 0.0;
  std::vector<Vector3f> sampled;  ///< the network's source points, source frame
  std::vector<double> prior;      ///< w_i·(1 + α·m_i): the network's SVD weights (docs/model.md)
  /// The sampled points' grey levels (colorIntensity); empty when the source has no colours.
  std::vector<float> sampled_grey;
  /// The same for every yaw hypothesis, best first by the registrar's ranking (the fields above are
  /// the first's).
  struct Hypothesis {
    Isometry3d T_target_source = Isometry3d::Identity();
    double alpha = 1.0, overlap = 0.0;
    std::vector<double> prior;
    double score = 0.0;  ///< what the registrar ranked it by (consensus share or fitness)
  };
  std::vector<Hypothesis> hypotheses;

  /// This stage as if hypothesis k had been ranked first.
  NetworkStage withHypothesis(std::size_t k) const {
    NetworkStage s = *this;
    s.T_target_source = hypotheses[k].T_target_source;
    s.alpha = hypotheses[k].alpha;
    s.overlap = hypotheses[k].overlap;
    s.prior = hypotheses[k].prior;
    return s;
  }
};

/// The network's SVD weights ω_i = w_i·(1 + α·m_i) (docs/model.md, step 8), with m_i the
/// membership of sampled source point i in the sampled overlap region.
std::vector<double> svdWeights(const std::vector<float>& inlier_weights,
                               const std::vector<float>& membership, double alpha, std::size_t n) {
  std::vector<double> prior;
  prior.reserve(n);
  for (std::size_t i = 0; i < n; ++i) {
    const double w = i < inlier_weights.size() ? double(inlier_weights[i]) : 1.0;
    const double m = i < membership.size() ? std::clamp(double(membership[i]), 0.0, 1.0) : 0.0;
    prior.push_back(w * (1.0 + alpha * m));
  }
  return prior;
}

NetworkStage runNetwork(const obmnet::ObmNetRegistrar& reg, const ObmNetMatcherParams& p,
                        const PointCloud& source, const PreparedTarget& target,
                        const Isometry3d& T_init) {
  NetworkStage s;
  obmnet::RegistrationResult r;
  try {
    if (p.pre_align) {
      // Network sees the source already moved by the guess; its output is the correction ΔT.
      r = reg.align(source.transformed(T_init, target.cloud().frame_id), target.cloud());
      s.T_target_source = r.T_target_source * T_init;
    } else {
      r = reg.align(source, target.cloud());
      s.T_target_source = r.T_target_source;
    }
  } catch (const ContractError& e) {
    // The network refuses clouds smaller than its neighbourhoods: an expected failure here.
    s.message = std::string("OBMNet: ") + e.what();
    return s;
  } catch (const std::exception& e) {
    // A numerical failure inside LibTorch (c10::Error, e.g. an SVD of non-finite values) fails
    // this match, not the whole run: the caller treats it as any failed match. Its first line
    // (LibTorch appends a stack trace) goes to the log.
    const std::string what = e.what();
    s.message = "OBMNet failed: " + what.substr(0, what.find('\n'));
    OBM_LOG_WARN("registration", s.message);
    return s;
  }
  if (!s.T_target_source.matrix().allFinite()) {
    s.message = "OBMNet: non-finite pose";
    return s;
  }
  s.ok = true;
  s.alpha = r.alpha;
  // The network's perplexity ratio can exceed 1 by float round-off; the result promises [0, 1].
  s.overlap = std::clamp(r.overlap, 0.0, 1.0);
  const std::size_t n = r.source_indices.size();
  s.sampled.reserve(n);
  // Indices refer to the cloud given to align(), which has the source's point order.
  for (std::size_t i = 0; i < n; ++i) s.sampled.push_back(source.points[r.source_indices[i]]);
  if (source.hasColors())
    for (std::size_t i = 0; i < n; ++i)
      s.sampled_grey.push_back(colorIntensity(source.colors[r.source_indices[i]]));
  for (const auto& h : r.hypotheses) {
    NetworkStage::Hypothesis y;
    y.T_target_source = p.pre_align ? h.T_target_source * T_init : h.T_target_source;
    y.alpha = h.alpha;
    y.overlap = std::clamp(h.overlap, 0.0, 1.0);
    y.prior = svdWeights(h.inlier_weights, h.overlap_membership, h.alpha, n);
    y.score = h.score;
    if (y.T_target_source.matrix().allFinite()) s.hypotheses.push_back(std::move(y));
  }
  if (p.hypothesis_free_space_weight > 0.0 && s.hypotheses.size() > 1 && !r.kept_start) {
    // The yaw hypotheses ranked by their score discounted by their free-space conflicts
    // (docs/registration.md, "Free space"): a street seen from its other end puts its cars and
    // poles into the road the target looked through.
    std::vector<Isometry3d> poses;
    std::vector<double> scores;
    for (const auto& h : s.hypotheses) {
      poses.push_back(h.T_target_source);
      scores.push_back(h.score);
    }
    const FreeSpaceCheck check(source.points, target.cloud().points, p.free_space);
    const std::size_t k =
        chooseByFreeSpace(poses, scores, check, p.hypothesis_free_space_weight);
    if (k > 0) {
      std::rotate(s.hypotheses.begin(), s.hypotheses.begin() + static_cast<std::ptrdiff_t>(k),
                  s.hypotheses.begin() + static_cast<std::ptrdiff_t>(k) + 1);
      s.T_target_source = s.hypotheses.front().T_target_source;
      s.alpha = s.hypotheses.front().alpha;
      s.overlap = s.hypotheses.front().overlap;
    }
  }
  // The returned pose is the fittest hypothesis's (finite, checked above): its weights are those.
  s.prior = !s.hypotheses.empty() && !r.kept_start
                ? s.hypotheses.front().prior
                : svdWeights(r.inlier_weights, r.overlap_membership, r.alpha, n);
  return s;
}

/// MatchResult::network_confidence: the share of the network's SVD weight on sampled source
/// points that have a target point within the inlier threshold at `T_target_source` (and, on
/// coloured pairs with ConfidenceParams::color_inlier_threshold, whose grey residual there is
/// within that: evaluateAlignment's inliers, on the network's points). With `plane_distance` > 0
/// a point must also lie within it of its nearest target point's tangent plane (of the point
/// itself where the normal is not trusted): ObmNetMatcherParams::choice_plane_distance.
double biasWeightedConfidence(const NetworkStage& net, const PreparedTarget& target,
                              const Isometry3d& T_target_source, const IcpParams& icp,
                              const ConfidenceParams& confidence, double plane_distance = 0.0) {
  const Eigen::Matrix3f R = T_target_source.linear().cast<float>();
  const Eigen::Vector3f t = T_target_source.translation().cast<float>();
  const bool color = colorInliersApply(icp, confidence, target,
                                       !net.sampled.empty() &&
                                           net.sampled_grey.size() == net.sampled.size());
  double num = 0.0, den = 0.0;
  std::size_t idx = 0;
  float d2 = 0.0f;
  for (std::size_t i = 0; i < net.sampled.size(); ++i) {
    const double w = net.prior[i];
    den += w;
    const Eigen::Vector3f x = R * net.sampled[i] + t;
    if (!target.nearest(x, confidence.inlier_threshold, idx, d2)) continue;
    if (color && std::abs(target.colorResidual(idx, x.cast<double>(), net.sampled_grey[i])) >
                     confidence.color_inlier_threshold)
      continue;
    if (plane_distance > 0.0) {
      const Eigen::Vector3f d = x - target.cloud().points[idx];
      const float off = target.normalValid()[idx] ? std::abs(target.normals()[idx].dot(d))
                                                  : d.norm();
      if (off > plane_distance) continue;
    }
    num += w;
  }
  return den > 0.0 ? num / den : 0.0;
}

/// What every OBMNet matcher adds to its pose: the network's α and overlap, then (when the pose
/// pairs enough points) the confidence, with the information weighted by the network's ω, and
/// the bias-weighted confidence.
MatchResult withNetworkConfidence(MatchResult result, const NetworkStage& net,
                                  const PointCloud& source, const PreparedTarget& target,
                                  const IcpParams& icp, const ConfidenceParams& confidence) {
  result.alpha = net.alpha;
  result.overlap = net.overlap;
  if (result.status == MatchStatus::TooFewCorrespondences) return result;
  // With coloured ICP the conditioning is that of the coloured cost, as IcpMatcher reports it (a
  // textured wall is not degenerate for it).
  const std::vector<float> grey = colorIntensities(source, target, icp);
  const AlignmentStats all =
      evaluateAlignment(source.points, nullptr, target, result.T_target_source, icp, confidence,
                        grey.empty() ? nullptr : &grey);
  const AlignmentStats info =
      evaluateAlignment(net.sampled, &net.prior, target, result.T_target_source, icp, confidence);
  applyConfidence(result, all, info, false, icp, confidence);
  result.network_confidence =
      biasWeightedConfidence(net, target, result.T_target_source, icp, confidence);
  return result;
}

MatchResult networkFailure(const NetworkStage& s, const Isometry3d& T_init) {
  MatchResult m;
  m.T_target_source = T_init;
  m.status = MatchStatus::TooFewPoints;
  m.message = s.message;
  return m;
}

}  // namespace

struct ObmNetMatcher::Impl {
  ObmNetMatcherParams params;
  obmnet::ObmNetRegistrar registrar;
};

ObmNetMatcher::ObmNetMatcher(const ObmNetMatcherParams& params, const IcpParams& icp,
                             const ConfidenceParams& confidence)
    : ScanMatcher(icp, confidence), impl_(new Impl{params, makeRegistrar(params, true)}) {}

ObmNetMatcher::~ObmNetMatcher() = default;

std::string ObmNetMatcher::describe() const {
  return impl_->registrar.describe();
}

MatchResult ObmNetMatcher::impl_match(const PointCloud& source, const PreparedTarget& target,
                                      const Isometry3d& T_target_source_init) const {
  const NetworkStage net =
      runNetwork(impl_->registrar, impl_->params, source, target, T_target_source_init);
  if (!net.ok) return networkFailure(net, T_target_source_init);
  MatchResult result;
  result.T_target_source = net.T_target_source;
  result.converged = true;
  result.start = MatchStart::Network;
  return withNetworkConfidence(std::move(result), net, source, target, icp_, confidence_);
}

struct ObmNetIcpMatcher::Impl {
  ObmNetMatcherParams params;
  obmnet::ObmNetRegistrar registrar;
};

ObmNetIcpMatcher::ObmNetIcpMatcher(const ObmNetMatcherParams& params, const IcpParams& icp,
                                   const ConfidenceParams& confidence)
    : ScanMatcher(icp, confidence) {
  if (!(params.start_turn_deg >= 0.0 && params.start_turn_deg <= 180.0))
    throw ConfigError("obmnet matcher: start_turn_deg must be in [0, 180] (0 = off)");
  if (const std::string why = startTurnAxesError(params.start_turn_axes); !why.empty())
    throw ConfigError("obmnet matcher: start_turn_axes: " + why);
  if (params.search_candidates < 0)
    throw ConfigError("obmnet matcher: search_candidates must be >= 0 (0 = off)");
  if (params.search_candidates > 0) params.search.validate();
  if (!(params.choice_plane_distance >= 0.0))
    throw ConfigError("obmnet matcher: choice_plane_distance must be >= 0 (0 = off)");
  if (!(params.choice_free_space_weight >= 0.0))
    throw ConfigError("obmnet matcher: choice_free_space_weight must be >= 0 (0 = off)");
  if (!(params.choice_inlier_power >= 0.0))
    throw ConfigError("obmnet matcher: choice_inlier_power must be >= 0 (0 = off)");
  if (!(params.hypothesis_free_space_weight >= 0.0))
    throw ConfigError("obmnet matcher: hypothesis_free_space_weight must be >= 0 (0 = off)");
  if (params.choice_free_space_weight > 0.0 || params.hypothesis_free_space_weight > 0.0)
    params.free_space.validate();
  impl_.reset(new Impl{params, makeRegistrar(params)});
}

ObmNetIcpMatcher::~ObmNetIcpMatcher() = default;

std::string ObmNetIcpMatcher::describe() const {
  return impl_->registrar.describe();
}

namespace {

/// One start of ObmNetIcpMatcher: the network from `T_target_source_init`, then ICP (with the
/// overlap stage, the hypotheses and the blind headings the parameters ask for). The pose is
/// returned before the confidence, with the network stage whose weights it carries; `net.ok` is
/// false when the network failed (then `result` says so).
struct Refinement {
  MatchResult result;
  NetworkStage net;
};

/// The free-space discount of a refined pose, max(0, 1 − λ·r) (ObmNetMatcherParams::
/// choice_free_space_weight); 1 without a check.
double freeSpaceDiscount(const FreeSpaceCheck* check, double weight,
                         const Isometry3d& T_target_source) {
  if (check == nullptr || weight <= 0.0) return 1.0;
  return std::max(0.0, 1.0 - weight * check->conflicts(T_target_source).ratio());
}

Refinement refineFrom(const obmnet::ObmNetRegistrar& registrar, const ObmNetMatcherParams& params,
                      const IcpParams& icp_, const ConfidenceParams& confidence_,
                      const PointCloud& source, const PreparedTarget& target,
                      const Isometry3d& T_target_source_init,
                      const FreeSpaceCheck* free_space = nullptr) {
  const NetworkStage net = runNetwork(registrar, params, source, target, T_target_source_init);
  if (!net.ok) return {networkFailure(net, T_target_source_init), net};
  Isometry3d T_start = net.T_target_source;
  MatchStart start = MatchStart::Network;
  if (params.keep_init_if_better) {
    // Which start explains more source points within the first (coarsest) ICP gate?
    IcpParams first = icp_;
    first.max_correspondence_distance =
        std::max(icp_.max_correspondence_distance, icp_.initial_max_correspondence_distance);
    const auto n_net =
        evaluateAlignment(source.points, nullptr, target, net.T_target_source, first, confidence_)
            .num_correspondences;
    const auto n_init =
        evaluateAlignment(source.points, nullptr, target, T_target_source_init, first, confidence_)
            .num_correspondences;
    if (n_init > n_net) {
      T_start = T_target_source_init;
      start = MatchStart::Guess;
      OBM_LOG_DEBUG("registration", "obmnet+icp: starting ICP from the initial guess ("
                                        << n_init << " vs " << n_net << " paired points)");
    }
  }
  const double keep = params.overlap_stage_keep;
  std::optional<Isometry3d> T_staged;
  if (keep > 0.0 && !net.sampled.empty()) {
    // Overlap stage: ICP on the points the network weights most (its SVD weights ω), so the
    // first refinement sees the overlap the network found rather than the whole partial cloud.
    std::vector<std::size_t> order(net.sampled.size());
    std::iota(order.begin(), order.end(), std::size_t{0});
    // keep ≤ 1, so 1 ≤ n_keep ≤ the number of sampled points; only the top n_keep are ordered
    // (ties by index, so the choice is deterministic).
    const auto n_keep = std::max<std::size_t>(
        1, static_cast<std::size_t>(std::lround(keep * static_cast<double>(order.size()))));
    std::partial_sort(order.begin(), order.begin() + static_cast<std::ptrdiff_t>(n_keep),
                      order.end(), [&](std::size_t a, std::size_t b) {
                        return net.prior[a] > net.prior[b] ||
                               (net.prior[a] == net.prior[b] && a < b);
                      });
    std::vector<Vector3f> core;
    core.reserve(n_keep);
    for (std::size_t i = 0; i < n_keep; ++i) core.push_back(net.sampled[order[i]]);
    IcpParams stage = icp_;
    stage.initial_max_correspondence_distance =
        params.overlap_stage_gate_factor * icp_.max_correspondence_distance;
    stage.polish_max_correspondence_distance = 0.0;
    const IcpOutcome o = runIcp(core, target, T_start, stage);
    if (o.status != MatchStatus::TooFewCorrespondences) T_staged = o.T_target_source;
  }
  // Coloured ICP's photometric term on the whole source when the clouds carry colours (the
  // overlap stage above runs on the network's sample, which has none).
  const std::vector<float> grey = colorIntensities(source, target, icp_);
  const std::vector<float>* source_grey = grey.empty() ? nullptr : &grey;
  IcpOutcome icp = runIcp(source.points, target, T_start, icp_, nullptr, source_grey);
  if (T_staged) {
    // Both refinements compete on the whole source: the one that pairs more points within the
    // fine gate wins (the stage can also be misled, e.g. by outliers among the weighted points).
    IcpOutcome staged = runIcp(source.points, target, *T_staged, icp_, nullptr, source_grey);
    if (staged.status != MatchStatus::TooFewCorrespondences &&
        (icp.status == MatchStatus::TooFewCorrespondences ||
         staged.num_correspondences > icp.num_correspondences))
      icp = std::move(staged);
  }
  // More hypotheses verified by ICP (refine_hypotheses), and blind headings from the guess
  // (init_headings): the network's fitness on its keypoints can prefer a wrong heading where ICP
  // from the right one explains more of the whole sweep. The refinements compete on their inliers
  // (source points within the confidence's inlier threshold), not on the pairs within the fine
  // gate: a pose slid along a street pairs nearly every point within a metre-wide gate.
  // With the free-space choice, the inliers are discounted by the pose's free-space conflicts.
  auto inliers = [&](const IcpOutcome& o) -> double {
    if (o.status == MatchStatus::TooFewCorrespondences) return 0.0;
    // Coloured inliers where the pair has colours (ConfidenceParams::color_inlier_threshold).
    return static_cast<double>(evaluateAlignment(source.points, nullptr, target,
                                                 o.T_target_source, icp_, confidence_,
                                                 source_grey)
                                   .num_inliers) *
           freeSpaceDiscount(free_space, params.choice_free_space_weight, o.T_target_source);
  };
  double icp_inliers = 0.0;
  auto compete = [&](IcpOutcome other, double margin) {
    const double n = inliers(other);
    if (other.status == MatchStatus::TooFewCorrespondences || n <= margin * icp_inliers)
      return false;
    icp = std::move(other);
    icp_inliers = n;
    return true;
  };
  std::size_t winner = 0;
  const std::size_t n_refine =
      params.refine_hypotheses == 0
          ? net.hypotheses.size()
          : std::min(net.hypotheses.size(),
                     static_cast<std::size_t>(std::max(1, params.refine_hypotheses)));
  const int headings = params.init_headings;
  if (n_refine > 1 || headings > 0) icp_inliers = inliers(icp);
  for (std::size_t k = 1; k < n_refine; ++k)
    if (compete(runIcp(source.points, target, net.hypotheses[k].T_target_source, icp_, nullptr,
                       source_grey),
                1.0))
      winner = k;
  bool heading_won = false;
  IcpParams wide = icp_;
  if (params.init_headings_gate > 0.0)
    wide.initial_max_correspondence_distance =
        std::max(params.init_headings_gate, icp_.max_correspondence_distance);
  for (int h = 0; h < headings; ++h) {
    const Isometry3d turn =
        makeIsometry(Eigen::AngleAxisd(360.0 * kDegToRad * h / headings, Eigen::Vector3d::UnitZ())
                         .toRotationMatrix(),
                     Eigen::Vector3d::Zero());
    // Against the network's best, not against an earlier heading: the margin is the network's.
    if (compete(runIcp(source.points, target, T_target_source_init * turn, wide, nullptr,
                       source_grey),
                heading_won ? 1.0 : params.init_headings_margin))
      heading_won = true;
  }
  MatchResult result = icp.toMatchResult();
  result.start = start;
  if (heading_won) {
    OBM_LOG_DEBUG("registration",
                  "obmnet+icp: a blind heading from the guess has the most inliers");
    result.start = MatchStart::Heading;
  } else if (winner > 0) {
    result.start = MatchStart::Hypothesis;
    return {std::move(result), net.withHypothesis(winner)};
  }
  return {std::move(result), net};
}

}  // namespace

MatchResult ObmNetIcpMatcher::impl_match(const PointCloud& source, const PreparedTarget& target,
                                         const Isometry3d& T_target_source_init) const {
  const ObmNetMatcherParams& p = impl_->params;
  // The free-space choice: both sweeps' range images once per pair.
  std::optional<FreeSpaceCheck> free_space;
  if (p.choice_free_space_weight > 0.0)
    free_space.emplace(source.points, target.cloud().points, p.free_space);
  const FreeSpaceCheck* check = free_space ? &*free_space : nullptr;
  Refinement best = refineFrom(impl_->registrar, p, icp_, confidence_, source, target,
                               T_target_source_init, check);
  // Further starts compete on the share of the network's SVD weight that lands on the target
  // (the bias-weighted confidence), which tells a start that arrived from one that did not
  // better than ICP's counts (docs/registration.md); with the free-space choice, discounted by
  // the pose's conflicts; with choice_inlier_power, times the share of the whole source's
  // inliers (coloured where the pair has colours) to that power.
  const std::vector<float> source_grey =
      p.choice_inlier_power > 0.0 || p.search_candidates > 0
          ? colorIntensities(source, target, icp_)
          : std::vector<float>();
  // `kind` and `index` name the start in the debug line only (index 0: none).
  auto score = [&](const Refinement& r, const char* kind, int index) {
    if (!r.net.ok || r.result.status == MatchStatus::TooFewCorrespondences) return -1.0;
    const double confidence = biasWeightedConfidence(r.net, target, r.result.T_target_source,
                                                     icp_, confidence_, p.choice_plane_distance);
    // The inlier share only when it counts (one pass over the whole source per start).
    const double share =
        p.choice_inlier_power > 0.0
            ? evaluateAlignment(source.points, nullptr, target, r.result.T_target_source, icp_,
                                confidence_, source_grey.empty() ? nullptr : &source_grey)
                  .inlier_ratio
            : 1.0;
    const double discount =
        freeSpaceDiscount(check, p.choice_free_space_weight, r.result.T_target_source);
    const double s = startChoiceScore(confidence, share, p.choice_inlier_power) * discount;
    // One line per refined start (obm-bench --log-level debug): which start won, and why. The
    // macro evaluates its expression only at that level.
    OBM_LOG_DEBUG("registration",
                  "obmnet+icp start " << kind << (index > 0 ? " " + std::to_string(index) : "")
                                      << ": "
                                      << rotationAngle(T_target_source_init.linear().transpose() *
                                                       r.result.T_target_source.linear()) *
                                             kRadToDeg
                                      << " deg, "
                                      << (r.result.T_target_source.translation() -
                                          T_target_source_init.translation())
                                             .norm()
                                      << " from the guess; confidence " << confidence
                                      << ", inlier share "
                                      << (p.choice_inlier_power > 0.0 ? std::to_string(share)
                                                                      : "not counted")
                                      << ", free-space factor " << discount << ", score " << s);
    return s;
  };
  double best_score =
      p.start_turn_deg > 0.0 || p.search_candidates > 0 ? score(best, "from the pair", 0) : -1.0;
  const NetworkStage first_net = p.search_candidates > 0 ? best.net : NetworkStage();
  if (p.start_turn_deg > 0.0) {
    // More starts: the source turned about its origin, p' = R·p, so the network (pre-aligned
    // by the guess or not) sees the pair from elsewhere; a pose T' of the turned source is the
    // pose T'·R of the source.
    int turn_index = 0;
    for (const Isometry3d& turn : startTurns(p.start_turn_deg, p.start_turn_axes)) {
      ++turn_index;
      const PointCloud turned = source.transformed(turn, source.frame_id);
      // The turn is about the sensor's origin, so the turned sweep has its own free space.
      std::optional<FreeSpaceCheck> turned_check;
      if (check) turned_check.emplace(turned.points, target.cloud().points, p.free_space);
      Refinement r = refineFrom(impl_->registrar, p, icp_, confidence_, turned, target,
                                T_target_source_init, turned_check ? &*turned_check : nullptr);
      // Back to the source's own frame: the pose, and the network's points (for the score, and
      // the confidence and the information, evaluated once below on the untouched source).
      r.result.T_target_source = r.result.T_target_source * turn;
      if (r.result.start == MatchStart::Guess) r.result.start = MatchStart::Turn;
      const Eigen::Matrix3f R_back = turn.linear().transpose().cast<float>();
      for (auto& q : r.net.sampled) q = R_back * q;
      const double s = score(r, "turn", turn_index);
      if (s <= best_score) continue;
      best = std::move(r);
      best_score = s;
    }
  }
  if (p.search_candidates > 0 && first_net.ok) {
    // Starts from the correlative search (docs/registration.md, "Correlative search"): ICP from
    // each of its poses, scored by the same bias-weighted confidence with the weights of the
    // network's first pass (its sampled points and ω are the source's, valid at any pose). A
    // network pass from each pose would cost a second per pose on depth frames and, measured
    // on the simulated frame pairs, registers the same pairs (docs/benchmarks.md).
    CorrelativeSearchParams sp = p.search;
    sp.candidates = p.search_candidates;
    const std::vector<float>* grey = source_grey.empty() ? nullptr : &source_grey;
    int hit_index = 0;
    for (const SearchHit& hit :
         correlativeSearch(source, target.cloud(), sp, T_target_source_init)) {
      const IcpOutcome o = runIcp(source.points, target, hit.T_target_source, icp_, nullptr, grey);
      Refinement r{o.toMatchResult(), first_net};
      r.result.start = MatchStart::Search;
      const double s = score(r, "search pose", ++hit_index);
      if (s <= best_score) continue;
      best = std::move(r);
      best_score = s;
    }
  }
  if (!best.net.ok) return best.result;
  return withNetworkConfidence(std::move(best.result), best.net, source, target, icp_,
                               confidence_);
}

struct ObmmIcpMatcher::Impl {
  ObmNetMatcherParams params;
  obmnet::ObmNetRegistrar registrar;
};

ObmmIcpMatcher::ObmmIcpMatcher(const ObmNetMatcherParams& params, const IcpParams& icp,
                               const ConfidenceParams& confidence)
    : ScanMatcher(icp, confidence), impl_(new Impl{params, makeRegistrar(params)}) {}

ObmmIcpMatcher::~ObmmIcpMatcher() = default;

MatchResult ObmmIcpMatcher::impl_match(const PointCloud& source, const PreparedTarget& target,
                                       const Isometry3d& T_target_source_init) const {
  const NetworkStage net =
      runNetwork(impl_->registrar, impl_->params, source, target, T_target_source_init);
  if (!net.ok) return networkFailure(net, T_target_source_init);
  // Every source point takes the module's weight of its nearest network point (the network saw a
  // sample of the source).
  PointCloud sampled;
  sampled.points = net.sampled;
  PreparedTargetOptions o;
  o.normal_neighbors = 3;
  o.threads = 1;
  const PreparedTarget index(sampled, o);
  std::vector<double> weights(source.size(), 0.0);
  double mean_w = 0.0;
  for (double w : net.prior) mean_w += w / static_cast<double>(net.prior.size());
  std::size_t j = 0;
  float d2 = 0.0f;
  for (std::size_t i = 0; i < source.size(); ++i)
    weights[i] = index.nearest(source.points[i], 1e30, j, d2) ? net.prior[j] / mean_w : 0.0;
  const IcpOutcome icp = runIcp(source.points, target, T_target_source_init, icp_, &weights);
  return withNetworkConfidence(icp.toMatchResult(), net, source, target, icp_, confidence_);
}

struct OverlapPredictor::Impl {
  ObmNetMatcherParams params;
  obmnet::ObmNetRegistrar registrar;
};

OverlapPredictor::OverlapPredictor(const ObmNetMatcherParams& params)
    : impl_(new Impl{params, makeRegistrar(params)}) {}

OverlapPredictor::~OverlapPredictor() = default;

OverlapPrediction OverlapPredictor::predict(const PointCloud& source,
                                            const PointCloud& target) const {
  auto weightsOf = [](const obmnet::RegistrationResult& r, std::vector<double>& w) {
    w.resize(r.inlier_weights.size());
    for (std::size_t i = 0; i < w.size(); ++i) {
      const double m = i < r.overlap_membership.size()
                           ? std::clamp(double(r.overlap_membership[i]), 0.0, 1.0)
                           : 0.0;
      w[i] = double(r.inlier_weights[i]) * (1.0 + r.alpha * m);
    }
  };
  OverlapPrediction out;
  const obmnet::RegistrationResult a = impl_->registrar.align(source, target);
  const obmnet::RegistrationResult b = impl_->registrar.align(target, source);
  out.source_points = a.source_sampled.points;
  out.target_points = b.source_sampled.points;
  weightsOf(a, out.source_weights);
  weightsOf(b, out.target_weights);
  out.alpha = a.alpha;
  return out;
}

#else  // no LibTorch

namespace {
[[noreturn]] void noTorch() {
  throw ConfigError(
      "obmnet matcher: this build has no OBMNet (configure with -DOBM_WITH_TORCH=ON and "
      "LibTorch installed)");
}
}  // namespace

struct ObmNetMatcher::Impl {};
struct ObmNetIcpMatcher::Impl {};

ObmNetMatcher::ObmNetMatcher(const ObmNetMatcherParams&, const IcpParams& icp,
                             const ConfidenceParams& confidence)
    : ScanMatcher(icp, confidence) {
  noTorch();
}
ObmNetMatcher::~ObmNetMatcher() = default;
std::string ObmNetMatcher::describe() const {
  return {};
}
MatchResult ObmNetMatcher::impl_match(const PointCloud&, const PreparedTarget&,
                                      const Isometry3d&) const {
  noTorch();
}

ObmNetIcpMatcher::ObmNetIcpMatcher(const ObmNetMatcherParams&, const IcpParams& icp,
                                   const ConfidenceParams& confidence)
    : ScanMatcher(icp, confidence) {
  noTorch();
}
ObmNetIcpMatcher::~ObmNetIcpMatcher() = default;
std::string ObmNetIcpMatcher::describe() const {
  return {};
}
MatchResult ObmNetIcpMatcher::impl_match(const PointCloud&, const PreparedTarget&,
                                         const Isometry3d&) const {
  noTorch();
}

struct ObmmIcpMatcher::Impl {};
ObmmIcpMatcher::ObmmIcpMatcher(const ObmNetMatcherParams&, const IcpParams& icp,
                               const ConfidenceParams& confidence)
    : ScanMatcher(icp, confidence) {
  noTorch();
}
ObmmIcpMatcher::~ObmmIcpMatcher() = default;
MatchResult ObmmIcpMatcher::impl_match(const PointCloud&, const PreparedTarget&,
                                       const Isometry3d&) const {
  noTorch();
}
struct OverlapPredictor::Impl {};
OverlapPredictor::OverlapPredictor(const ObmNetMatcherParams&) {
  noTorch();
}
OverlapPredictor::~OverlapPredictor() = default;
OverlapPrediction OverlapPredictor::predict(const PointCloud&, const PointCloud&) const {
  noTorch();
}

#endif

std::string startTurnAxesError(const std::string& axes) {
  if (axes.empty()) return "name at least one axis (x, y or z)";
  for (std::size_t i = 0; i < axes.size(); ++i) {
    if (axes[i] != 'x' && axes[i] != 'y' && axes[i] != 'z')
      return std::string("'") + axes[i] + "' is not an axis (x, y or z)";
    if (axes.find(axes[i]) != i) return std::string("axis '") + axes[i] + "' named twice";
  }
  return {};
}

double startChoiceScore(double confidence, double inlier_share, double inlier_power) {
  return inlier_power > 0.0 ? confidence * std::pow(inlier_share, inlier_power) : confidence;
}

std::vector<Isometry3d> startTurns(double deg, const std::string& axes) {
  std::vector<Isometry3d> turns;
  if (deg == 0.0) return turns;
  for (const char axis : axes)
    for (const double sign : {1.0, -1.0}) {
      const Eigen::Vector3d u = axis == 'x'   ? Eigen::Vector3d::UnitX()
                                : axis == 'y' ? Eigen::Vector3d::UnitY()
                                              : Eigen::Vector3d::UnitZ();
      turns.push_back(makeIsometry(Eigen::AngleAxisd(sign * deg * kDegToRad, u).toRotationMatrix(),
                                   Eigen::Vector3d::Zero()));
    }
  return turns;
}

bool obmNetAvailable() noexcept {
#ifdef OBM_REGISTRATION_HAS_OBMNET
  return true;
#else
  return false;
#endif
}

}  // namespace obm::registration
