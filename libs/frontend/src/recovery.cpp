#include "recovery.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <map>
#include <memory>
#include <utility>
#include <vector>

#include "local_map.hpp"
#include "matcher_stage.hpp"
#include "obm/core/log.hpp"
#include "obm/frontend/stages.hpp"
#include "tracker.hpp"

namespace obm::frontend {

namespace {
constexpr const char* kLog = "frontend";
}  // namespace

/// One frame's recovery: the input, the bounds, and what the steps so far found.
struct Recovery::Attempt {
  const RecoveryInput& in;
  FrameResult& fr;
  StageTimes& times;
  /// Why tracking was rejected, followed by each failed step's finding; a step that takes the
  /// frame reports this reason and what it took.
  std::string reason;
  /// Appended to the reason only when every step fails (the last_keyframe step's finding: the
  /// steps after it judge the same registration).
  std::string trailer;
  AcceptanceBounds recovered;  ///< a recovered registration
  AcceptanceBounds confirmed;  ///< one taken on a confirmation (second opinion, jump)
  /// The best wide-gate registration that fails only the relative inlier ratio.
  std::optional<registration::MatchResult> near;
  /// The last_keyframe step's registration (world frame) and why it was not taken.
  std::optional<registration::MatchResult> keyframe_match;
  std::string keyframe_why;

  bool take(const registration::MatchResult& match, const std::string& how) {
    fr.match = match;
    fr.status = TrackingStatus::Recovered;
    fr.reason = reason + "; taken: " + how;
    return true;
  }
};

const Recovery::Step Recovery::kSteps[] = {
    {"wide_gate", &Recovery::wideGate},           {"gap_paths", &Recovery::gapPaths},
    {"last_keyframe", &Recovery::lastKeyframe},   {"second_opinion", &Recovery::secondOpinion},
    {"confirmed_jump", &Recovery::confirmedJump},
};

std::vector<std::string> Recovery::stepNames() {
  std::vector<std::string> names;
  for (const Step& s : kSteps) names.emplace_back(s.name);
  return names;
}

Recovery::Recovery(const TrackingParams& params, const registration::IcpMatcher* wide_gate,
                   const registration::ScanMatcher& matcher)
    : params_(params), wide_gate_(wide_gate), matcher_(matcher) {}

void Recovery::startSweep() {
  previous_.reset();
  previous_.swap(candidate_);
}

std::optional<JumpCandidate> Recovery::takeConfirmedJump() {
  std::optional<JumpCandidate> jump;
  jump.swap(confirmed_);
  return jump;
}

void Recovery::recover(const RecoveryInput& in, const Rejection& rejection, FrameResult& fr,
                       StageTimes& times) {
  const TrackingParams& tp = params_;
  fr.rejection = rejection.kind;
  Attempt a{in, fr, times, rejection.detail, {}, {}, {}, {}, {}, {}};
  const double max_rot = tp.recoveryMaxRotation() + in.extrapolated_rotation;
  a.recovered = {tp.recovery_min_quality, tp.recovery_relative_inlier_ratio * in.inlier_reference,
                 tp.recovery_max_correction, max_rot};
  a.confirmed = a.recovered;
  a.confirmed.min_inlier_ratio = tp.recovery_confirmed_relative_inlier_ratio * in.inlier_reference;
  taken_by_.clear();
  recovery_map_.reset();
  for (const Step& step : kSteps)
    if ((this->*step.run)(a)) {
      taken_by_ = step.name;
      return;
    }
  fr.status = TrackingStatus::Bridged;
  fr.reason = a.reason + a.trailer;
}

/// T_a and T_b within `translation` [m] and `rotation` [rad] of each other.
static bool withinOf(const Isometry3d& T_a, const Isometry3d& T_b, double translation,
                     double rotation) {
  const Isometry3d d = T_a.inverse() * T_b;
  return d.translation().norm() <= translation && rotationAngle(d.linear()) <= rotation;
}

bool Recovery::agree(const Isometry3d& T_a, const Isometry3d& T_b) const {
  return withinOf(T_a, T_b, params_.recovery_agreement_translation,
                  params_.recovery_agreement_rotation);
}

/// Hypotheses: the guess, then the guess turned about the axis of the last motion (a car's
/// vertical) by ±k·step — a wrong turn rate is the usual cause of a lost track.
bool Recovery::wideGate(Attempt& a) {
  if (wide_gate_ == nullptr) return false;
  const TrackingParams& tp = params_;
  const RecoveryInput& in = a.in;
  Eigen::Vector3d axis = logSO3(in.last_motion.linear());
  axis = axis.norm() > 0.5 * kDegToRad ? axis.normalized() : Eigen::Vector3d::UnitZ();
  std::vector<double> angles{0.0};
  // Over a gap the hypotheses cover the extrapolated turn too.
  const int k_max = tp.recovery_rotation_hypotheses == 0
                        ? 0
                        : std::max(tp.recovery_rotation_hypotheses,
                                   static_cast<int>(std::ceil(
                                       in.extrapolated_rotation / tp.recovery_rotation_step)));
  for (int k = 1; k <= k_max; ++k) {
    angles.push_back(k * tp.recovery_rotation_step);
    angles.push_back(-k * tp.recovery_rotation_step);
  }
  // A registration beyond the rotation bound that fits as well as the tracked frames is taken
  // (sweeps lost in a turn with regular stamps: the guess falls short of the turn).
  AcceptanceBounds bounds = a.recovered;
  bounds.large_turn_min_inlier_ratio =
      tp.recovery_large_turn_relative_inlier_ratio * in.inlier_reference;
  registration::MatchResult best;
  bool found = false;
  std::string why;
  for (double angle : angles) {
    Isometry3d T_start = in.T_guess;
    T_start.linear() = in.T_guess.linear() * expSO3(angle * axis);
    registration::MatchResult r;
    {
      TimedStage s(a.times, Stage::Icp);
      r = wide_gate_->match(in.source, in.local_map, T_start);
    }
    const Rejection w = checkAcceptance(r, in.T_guess, bounds);
    OBM_LOG_DEBUG(kLog, "frame " << a.fr.index << ": wide-gate recovery from "
                                 << angle * kRadToDeg << " deg: inlier ratio " << r.inlier_ratio
                                 << ", fitness " << r.fitness
                                 << (w.rejected() ? " (" + w.detail + ")" : ""));
    if (!w.rejected() && (!found || r.inlier_ratio > best.inlier_ratio)) {
      best = r;
      found = true;
      if (r.inlier_ratio >= in.inlier_reference) break;  // as good as normal tracking: done
    } else if (why.empty() && w.rejected()) {
      why = w.detail;
    }
    // Fails only the relative inlier ratio: a candidate for the second opinion.
    if (w.rejected() && tp.recovery_agreement_translation > 0.0 &&
        !checkAcceptance(r, in.T_guess, a.confirmed).rejected() &&
        (!a.near || r.inlier_ratio > a.near->inlier_ratio))
      a.near = r;
  }
  if (found) return a.take(best, "the wide-gate recovery");
  a.reason += "; wide-gate recovery: " + why;
  return false;
}

/// Over a gap of n steps the constant-velocity guess drives the last motion n times: a turn
/// continued for the whole gap, at the same speed. A car leaves a turn and changes speed, so the
/// hypotheses are the paths that turn at the last turn rate for part of the gap (every
/// recovery_gap_turn_step of heading, up to the whole extrapolated turn) and drive straight for
/// the rest, at speeds from recovery_gap_speed_min to _max; each starts the wide-gate ICP against
/// the local map. The guess bounds nothing here (it may be tens of metres and degrees off); instead
/// the registrations are judged against one another: the fittest acceptable one is taken when at
/// least recovery_gap_min_support starts reach it (a basin, not one start's accident) and no
/// acceptable registration elsewhere pairs nearly as many points (recovery_gap_rival_ratio: a
/// street of repeated blocks offers several poses that fit alike).
bool Recovery::gapPaths(Attempt& a) {
  const TrackingParams& tp = params_;
  const RecoveryInput& in = a.in;
  if (wide_gate_ == nullptr || in.last_bridged) return false;
  // A gap the time stamps show: its length is known, the speed is not. A jump they hide (sweeps
  // lost, stamps rewritten): the guess is one step, the lost steps are unknown.
  const bool gap = tp.recovery_gap_min_steps > 0.0 && in.steps >= tp.recovery_gap_min_steps;
  const bool jump = !gap && tp.recovery_jump_max_steps > 0 && in.steps < 1.5;
  if (!gap && !jump) return false;
  const Eigen::Matrix<double, 6, 1> xi = logSE3(in.last_motion);  // translation first
  const Eigen::Vector3d v = xi.head<3>(), w = xi.tail<3>();
  // The path lengths, so that the ends of neighbouring paths are at most
  // recovery_gap_start_spacing apart (ICP's basin along a street is a few metres).
  const double step_length = std::max(v.norm(), 1e-3);
  std::vector<std::pair<double, double>> lengths;  // (steps, speed factor)
  if (gap) {
    const double lo = tp.recovery_gap_speed_min, hi = tp.recovery_gap_speed_max;
    const int k = std::max(1, static_cast<int>(std::ceil((hi - lo) * in.steps * step_length /
                                                         tp.recovery_gap_start_spacing)));
    for (int i = 0; i <= k; ++i) lengths.emplace_back(in.steps, lo + (hi - lo) * i / k);
  } else {
    const int every =
        std::max(1, static_cast<int>(std::floor(tp.recovery_gap_start_spacing / step_length)));
    for (int lost = every; lost <= tp.recovery_jump_max_steps; lost += every)
      lengths.emplace_back(1.0 + lost, 1.0);
  }
  const double turn_per_step = w.norm();
  AcceptanceBounds bounds = a.recovered;
  bounds.min_inlier_ratio = tp.recovery_gap_relative_inlier_ratio * in.inlier_reference;
  bounds.max_correction = std::numeric_limits<double>::infinity();
  bounds.max_rotation = std::numeric_limits<double>::infinity();
  // The starts: the turn continued for part of the path; after a straight stretch (no turn to
  // continue) also a corner taken half-way, either side (a street corner inside the gap).
  struct Start {
    Isometry3d T;
    double n, speed, turn;  // steps, speed factor, [rad] heading change
  };
  std::vector<Start> starts;
  const bool straight = turn_per_step * in.steps < tp.recovery_gap_turn_step;
  const Eigen::Vector3d up = Eigen::Vector3d::UnitZ();
  for (const auto& [n, speed] : lengths) {
    std::vector<double> turn_steps{0.0};  // steps of turning before driving straight
    if (turn_per_step * n > 1e-3) {
      for (double th = tp.recovery_gap_turn_step; th < n * turn_per_step;
           th += tp.recovery_gap_turn_step)
        turn_steps.push_back(th / turn_per_step);
      turn_steps.push_back(n);
    }
    for (double m : turn_steps) {
      Eigen::Matrix<double, 6, 1> turn;
      turn << speed * m * v, m * w;
      Isometry3d T = in.T_last * expSE3(turn);
      T.translation() += T.linear() * (speed * (n - m) * v);
      starts.push_back({T, n, speed, m * turn_per_step});
    }
    if (straight)
      for (double corner : tp.recovery_gap_corner_turns)
        for (double sign : {1.0, -1.0}) {
          Isometry3d T = in.T_last;
          T.translation() += T.linear() * (0.5 * speed * n * v);
          T.linear() = T.linear() * Eigen::AngleAxisd(sign * corner, up).toRotationMatrix();
          T.translation() += T.linear() * (0.5 * speed * n * v);
          starts.push_back({T, n, speed, sign * corner});
        }
  }
  std::vector<registration::MatchResult> ok;
  // What each acceptable registration was made against: the local map, or the earlier map at a
  // keyframe (the key of `submaps` below).
  constexpr std::size_t kLocalMap = std::numeric_limits<std::size_t>::max();
  std::vector<std::size_t> ok_on;
  std::map<std::size_t, std::unique_ptr<registration::PreparedTarget>> submaps;
  // The wide-gate ICP of the sweep from a path's end against `target`; an acceptable
  // registration that came to rest joins `ok`.
  const auto tryStart = [&](const Start& st, const registration::PreparedTarget& target,
                            std::size_t on) {
    registration::MatchResult r;
    {
      TimedStage s(a.times, Stage::Icp);
      r = wide_gate_->match(in.source, target, st.T);
      // Tens of metres from the start the iteration limit may stop ICP on its way: a
      // registration that already fits is continued once from where it stopped.
      if (r.status == registration::MatchStatus::NotConverged &&
          !checkAcceptance(r, in.T_guess, bounds).rejected())
        r = wide_gate_->match(in.source, target, r.T_target_source);
    }
    const Rejection why = checkAcceptance(r, in.T_guess, bounds);
    OBM_LOG_DEBUG(kLog, "frame " << a.fr.index << ": " << (gap ? "gap" : "jump") << " path of "
                                 << st.n << " steps turning " << st.turn * kRadToDeg
                                 << " deg, speed x" << st.speed << ", against "
                                 << (on == kLocalMap ? std::string("the local map")
                                                     : "the map at keyframe " + std::to_string(on))
                                 << ": inlier ratio " << r.inlier_ratio << ", quality " << r.quality
                                 << ", " << toString(r.status)
                                 << (why.rejected() ? " (" + why.detail + ")" : ""));
    // Only registrations that came to rest compete: one stopped by the iteration limit is still
    // sliding (along a street, towards the basin another start reached).
    if (!why.rejected() && r.status == registration::MatchStatus::Ok) {
      ok.push_back(r);
      ok_on.push_back(on);
    }
  };
  for (const Start& st : starts) tryStart(st, in.local_map, kLocalMap);
  // The map made earlier around each path's end (gaps only: a jump is a few sweeps long).
  int map_targets = 0;
  if (gap && tp.recovery_gap_map_radius > 0.0 && in.all_keyframes != nullptr &&
      in.old_keyframes_end > 0) {
    const std::vector<Keyframe>& kfs = *in.all_keyframes;
    const std::size_t end = std::min(in.old_keyframes_end, kfs.size());
    const double r2 = tp.recovery_gap_map_radius * tp.recovery_gap_map_radius;
    for (const Start& st : starts) {
      std::size_t nearest = end;
      double best_d2 = r2;
      for (std::size_t k = 0; k < end; ++k) {
        if (kfs[k].dropped) continue;
        const double d2 = (kfs[k].T_world_sensor.translation() - st.T.translation()).squaredNorm();
        if (d2 <= best_d2) {
          best_d2 = d2;
          nearest = k;
        }
      }
      if (nearest == end) continue;
      std::unique_ptr<registration::PreparedTarget>& target = submaps[nearest];
      if (!target) {
        std::vector<std::size_t> near;
        const Eigen::Vector3d centre = kfs[nearest].T_world_sensor.translation();
        for (std::size_t k = 0; k < end; ++k)
          if (!kfs[k].dropped &&
              (kfs[k].T_world_sensor.translation() - centre).squaredNorm() <= r2)
            near.push_back(k);
        const PointCloud merged =
            mergeKeyframeClouds(kfs, near, Isometry3d::Identity(), in.map_voxel);
        TimedStage s(a.times, Stage::LocalMap);
        target = std::make_unique<registration::PreparedTarget>(wide_gate_->prepare(merged));
        ++map_targets;
      }
      tryStart(st, *target, nearest);
    }
  }
  const std::string what = gap ? "gap paths" : "jump paths";
  const std::string against =
      map_targets > 0 ? " (local map and " + std::to_string(map_targets) + " earlier submaps)" : "";
  if (ok.empty()) {
    a.reason += "; " + what + ": no acceptable registration from " + std::to_string(starts.size()) +
                " starts" + against;
    return false;
  }
  const auto best = std::max_element(ok.begin(), ok.end(), [](const auto& x, const auto& y) {
    return x.inlier_ratio < y.inlier_ratio;
  });
  int support = 0;
  double rival = 0.0;
  for (const registration::MatchResult& r : ok) {
    if (withinOf(best->T_target_source, r.T_target_source, tp.recovery_gap_agreement_translation,
                 tp.recovery_gap_agreement_rotation))
      ++support;
    else
      rival = std::max(rival, r.inlier_ratio);
  }
  const Isometry3d d = in.T_last.inverse() * best->T_target_source;
  char found[160];
  std::snprintf(found, sizeof(found),
                "%.1f m / %.1f deg from the last frame, inlier ratio %.3f, %d of %zu acceptable "
                "starts agree, best elsewhere %.3f",
                d.translation().norm(), rotationAngle(d.linear()) * kRadToDeg, best->inlier_ratio,
                support, ok.size(), rival);
  if (support >= tp.recovery_gap_min_support &&
      rival < tp.recovery_gap_rival_ratio * best->inlier_ratio) {
    // Taken against the earlier map: the local map (the keyframes before the gap) may not reach
    // where the car is now, so the next frames track against that map (takeRecoveryMap()).
    const std::size_t on = ok_on[static_cast<std::size_t>(best - ok.begin())];
    if (on != kLocalMap) recovery_map_ = std::move(submaps[on]);
    return a.take(*best, "the " + what + against + " (" + found + ")");
  }
  a.reason += "; " + what + " ambiguous" + against + ": " + found;
  return false;
}

/// The scan matcher against the last keyframe, from the same guess (pre-aligned for the
/// network): a different target than the local map and the matcher's own wide, annealed gate.
/// After a jump of several metres it can land beyond the correction bound, where only the
/// confirmed_jump step may take it.
bool Recovery::lastKeyframe(Attempt& a) {
  const RecoveryInput& in = a.in;
  const Keyframe& kf = in.last_keyframe;
  registration::MatchResult r;
  {
    TimedStage s(a.times, matcherStage(matcher_));
    if (!last_keyframe_target_)
      last_keyframe_target_ =
          std::make_unique<registration::PreparedTarget>(matcher_.prepare(kf.cloud));
    r = matcher_.match(in.source, *last_keyframe_target_, kf.T_world_sensor.inverse() * in.T_guess);
  }
  r.T_target_source = kf.T_world_sensor * r.T_target_source;
  {
    const Isometry3d d = in.T_guess.inverse() * r.T_target_source;
    OBM_LOG_DEBUG(kLog, "frame " << a.fr.index << ": " << matcher_.name()
                                 << " recovery against keyframe " << kf.id << ": status "
                                 << toString(r.status) << ", quality " << r.quality
                                 << ", inlier ratio " << r.inlier_ratio << ", pairs "
                                 << r.num_correspondences << ", correction "
                                 << d.translation().norm() << " m / "
                                 << rotationAngle(d.linear()) * kRadToDeg << " deg");
  }
  a.keyframe_match = r;
  const Rejection kr = checkAcceptance(r, in.T_guess, a.recovered);
  if (!kr.rejected()) return a.take(r, matcher_.name() + " against the last keyframe");
  a.keyframe_why = kr.detail;
  a.trailer = "; " + matcher_.name() + " recovery: " + a.keyframe_why;
  return false;
}

/// Two registrations against different targets (local map, last keyframe) that land on the same
/// pose (TrackingParams::recovery_agreement_translation): the wide-gate one is taken.
bool Recovery::secondOpinion(Attempt& a) {
  if (!a.near || !a.keyframe_match) return false;
  const registration::MatchResult& r = *a.keyframe_match;
  if (checkAcceptance(r, a.in.T_guess, a.confirmed).rejected()) return false;
  if (!agree(a.near->T_target_source, r.T_target_source)) return false;
  return a.take(*a.near, "the wide-gate recovery, confirmed by " + matcher_.name() +
                             " against the last keyframe");
}

/// A sudden jump (TrackingParams::recovery_confirm_jumps): a registration metres from the guess
/// is not bounded here, but it is taken only when the next sweep's lands on it moved by the
/// constant-velocity step (two sweeps, two registrations against the keyframe). Otherwise this
/// sweep's registration becomes the candidate the next sweep may confirm.
bool Recovery::confirmedJump(Attempt& a) {
  if (!params_.recovery_confirm_jumps || !a.keyframe_match) return false;
  const RecoveryInput& in = a.in;
  const registration::MatchResult& r = *a.keyframe_match;
  constexpr double kAny = std::numeric_limits<double>::infinity();
  AcceptanceBounds unbounded = a.confirmed;
  unbounded.max_correction = kAny;
  unbounded.max_rotation = kAny;
  if (checkAcceptance(r, in.T_guess, unbounded).rejected()) return false;
  if (previous_ && previous_->frame + 1 == a.fr.index && previous_->keyframes == in.keyframes) {
    const Isometry3d T_predicted =
        previous_->T_world_sensor * (previous_->T_guess.inverse() * in.T_guess);
    if (agree(T_predicted, r.T_target_source)) {
      const Isometry3d jump = in.T_guess.inverse() * r.T_target_source;
      confirmed_ = previous_;
      return a.take(r, "a jump of " + std::to_string(jump.translation().norm()) + " m / " +
                           std::to_string(rotationAngle(jump.linear()) * kRadToDeg) +
                           " deg, registered by " + matcher_.name() +
                           " on this sweep and the one before");
    }
  }
  candidate_ = JumpCandidate{a.fr.index, in.keyframes, in.T_guess, r.T_target_source};
  return false;
}

}  // namespace obm::frontend
