#include "obm/frontend/stages.hpp"
#include "obm/frontend/frontend.hpp"

#include <algorithm>
#include <filesystem>
#include <optional>
#include <random>

#include "edge_information.hpp"
#include "local_map.hpp"
#include "loop_closer.hpp"
#include "obm/backend/optimizer.hpp"
#include "obm/core/cloud_ops.hpp"
#include "obm/core/errors.hpp"
#include "obm/core/log.hpp"
#include "obm/frontend/keyframe_selector.hpp"
#include "obm/frontend/motion_model.hpp"
#include "obm/registration/obmnet_matcher.hpp"
#include "recovery.hpp"
#include "relocaliser.hpp"
#include "tracker.hpp"

namespace obm::frontend {

namespace {

constexpr const char* kLog = "frontend";

struct FrameRecord {
  double timestamp = 0.0;
  std::size_t keyframe = 0;
  Isometry3d T_keyframe_frame = Isometry3d::Identity();
  TrackingStatus status = TrackingStatus::Initial;
};

}  // namespace

const char* toString(TrackingStatus status) {
  switch (status) {
    case TrackingStatus::Initial:
      return "initial";
    case TrackingStatus::Tracked:
      return "tracked";
    case TrackingStatus::Recovered:
      return "recovered";
    case TrackingStatus::Bridged:
      return "bridged";
  }
  return "?";
}

MatcherChoice chooseMatcher(const FrontendParams& params) {
  MatcherChoice c;
  c.config = params.matcher;
  const std::string type = toString(c.config.type);
  if (!registration::usesNetwork(c.config.type)) {
    c.message = "matcher: " + type;
    return c;
  }
  const std::string& model = c.config.obmnet.network.model_path;
  const bool available = registration::obmNetAvailable();
  if (available && std::filesystem::is_regular_file(model)) {
    c.message = "matcher: " + type + " (model " + model + ")";
    return c;
  }
  const std::string why =
      available ? "the OBMNet model '" + model + "' of matcher.type '" + type + "' does not exist"
                : "this build has no OBMNet (LibTorch) to run the model '" + model + "'";
  if (!params.matcher_fallback) {
    if (!available)
      throw ConfigError("matcher.type '" + type + "': " + why + " (set matcher.fallback: icp)");
    throw IoError("matcher: the OBMNet model '" + model + "' of matcher.type '" + type +
                  "' does not exist (train one with obm-train, or set matcher.fallback: icp)");
  }
  if (registration::usesNetwork(*params.matcher_fallback))
    throw ConfigError("matcher.fallback: '" + std::string(toString(*params.matcher_fallback)) +
                      "' needs the same missing model '" + model + "'; use icp");
  c.config.type = *params.matcher_fallback;
  c.fell_back = true;
  c.message = "matcher: " + std::string(toString(c.config.type)) + " (fallback: " + why + ")";
  return c;
}

/// The front-end: one frame at a time through preprocessing, the tracker (with the recovery
/// steps when its match is rejected), keyframes (pose-graph nodes with odometry edges, members of
/// the local map) and the loop closer; the pose graph is optimised after an accepted loop.
struct Frontend::Impl {
  FrontendParams p;
  std::unique_ptr<registration::ScanMatcher> matcher;  // loop verification, last-resort recovery
  KeyframeSelector selector;
  double inl_ref_before = 0.0;  ///< the tracker's recent inlier ratio before the current frame
  ConstantVelocityModel motion;
  std::mt19937_64 rng;
  backend::Optimizer optimizer;
  bool validated;  // p.validate() has run: the parts below are built from valid parameters
  Tracker tracker;          // frame → local map, acceptance tests
  Recovery recovery;        // the steps after a rejected tracking match
  LocalMap local_map;       // the newest keyframes' clouds, rebuilt asynchronously
  LoopCloser loop_closer;   // candidates, verification, loop edges
  Relocaliser relocaliser;  // a piece after a restart, back onto the map

  std::vector<Keyframe> keyframes;
  std::vector<FrameRecord> frames;
  std::vector<LoopClosure> loops;
  std::size_t frames_since_keyframe = 0;
  std::size_t bridge_run = 0;
  bool jumped_last_frame = false;  // the last frame's recovery was taken as a jump
  Isometry3d T_world_current = Isometry3d::Identity();
  double travelled = 0.0;
  bool finished = false;
  FrontendStats stats;
  StageTimes times;

  Impl(const FrontendParams& params, std::unique_ptr<registration::ScanMatcher> m)
      : p(params),
        matcher(std::move(m)),
        selector(params.keyframes),
        rng(params.preprocess.seed),
        optimizer(params.optimizer),
        validated((p.validate(), true)),
        tracker(p.tracking),
        recovery(p.tracking, tracker.wideGate(), *matcher),
        local_map(p.local_map, tracker.icp().icpParams().targetOptions()),
        loop_closer(p.loop_closure, p.local_map.voxel, *matcher),
        relocaliser(p.loop_closure.relocalisation, loop_closer) {}

  // ---------------------------------------------------------------------------------------
  FrameResult process(const PointCloud& sweep) {
    OBM_ASSERT(!finished, "Frontend::process called after finish()");
    FrameResult fr;
    fr.index = frames.size();
    fr.timestamp = sweep.timestamp;
    ++stats.frames;

    PointCloud cropped, source;
    const bool usable = preprocess(sweep, fr, cropped, source);

    // The first usable sweep starts the map at the identity.
    if (keyframes.empty()) {
      fr.status = TrackingStatus::Initial;
      if (usable) {
        addKeyframe(fr.index, sweep.timestamp, Isometry3d::Identity(), cropped, nullptr, false);
        fr.keyframe = true;
        motion.update(Isometry3d::Identity(), sweep.timestamp);
      } else {
        fr.rejection = RejectionKind::NoSweep;
        fr.reason = "no usable sweep yet";
      }
      record(fr, Isometry3d::Identity());
      return fr;
    }

    local_map.installPending(fr.index, times);
    const Isometry3d T_guess = motion.predict(sweep.timestamp, p.tracking.use_timestamps);
    Isometry3d T = T_guess;
    if (!usable) {
      fr.status = TrackingStatus::Bridged;
      fr.rejection = RejectionKind::NoSweep;
      fr.reason = "unusable sweep (" + std::to_string(source.size()) + " points after cleaning)";
    } else {
      track(source, T_guess, fr);
      if (fr.status != TrackingStatus::Bridged) T = fr.match.T_target_source;
    }
    correctMotion(T_guess, T, fr.status);
    count(fr);
    travelled += (T_world_current.inverse() * T).translation().norm();
    motion.update(T, sweep.timestamp);
    T_world_current = T;
    ++frames_since_keyframe;

    // Only tracked frames become keyframes: a recovered pose is less certain and must not put
    // its cloud into the local map (a wrong one would make the following frames consistently
    // wrong).
    if (fr.status == TrackingStatus::Tracked) {
      if (selector.isKeyframe(keyframes.back().T_world_sensor, T, frames_since_keyframe,
                              fr.match.inlier_ratio, inl_ref_before)) {
        addKeyframe(fr.index, sweep.timestamp, T, cropped, &fr.match, false);
        fr.keyframe = true;
      }
    } else if (fr.status == TrackingStatus::Bridged && bridge_run >= p.tracking.max_bridge_frames &&
               usable) {
      restartLocalMap(fr, sweep.timestamp, T, cropped);
    }
    if (fr.keyframe) fr.loops_accepted = closeLoops();
    fr.T_world_sensor = T_world_current;
    record(fr, T_world_current);
    return fr;
  }

  /// Cleans and crops the sweep into `cropped` (the keyframe cloud is made from it) and thins it
  /// into `source` (what is registered). False when too few points are left to register.
  bool preprocess(const PointCloud& sweep, FrameResult& fr, PointCloud& cropped,
                  PointCloud& source) {
    {
      TimedStage s(times, Stage::Preprocess);
      cropped = cleanAndCrop(sweep, p.preprocess.min_range, p.preprocess.max_range, &fr.preprocess);
      source = p.preprocess.voxel > 0.0 ? voxelDownsample(cropped, p.preprocess.voxel) : cropped;
      if (p.preprocess.max_points > 0 && source.size() > p.preprocess.max_points)
        source = randomSubset(source, p.preprocess.max_points, rng);
      fr.preprocess.points_out = source.size();
    }
    const auto min_points = static_cast<std::size_t>(p.tracking.icp.min_correspondences);
    const bool usable = source.size() >= min_points;
    if (!usable) {
      ++stats.empty_sweeps;
      OBM_LOG_WARN_THROTTLE(kLog, 2.0,
                            "frame " << fr.index << ": unusable sweep (" << fr.preprocess.points_in
                                     << " points, " << fr.preprocess.non_finite << " non-finite, "
                                     << fr.preprocess.cropped << " out of range, " << source.size()
                                     << " left)");
    }
    return usable;
  }

  /// The tracker registers the sweep against the local map; when it rejects the match, the
  /// recovery steps run (and may bridge the frame).
  void track(const PointCloud& source, const Isometry3d& T_guess, FrameResult& fr) {
    recovery.startSweep();
    const double inl_ref = tracker.recentInlierRatio();
    inl_ref_before = inl_ref;
    const bool have_velocity = motion.count() >= 2;
    std::optional<Isometry3d> matcher_start;
    if (!have_velocity && p.tracking.start_search_matcher) matcher_start = matcherStart(source);
    const Rejection rejection =
        tracker.track(source, local_map.target(), T_guess, have_velocity, fr.match, times,
                      matcher_start ? &*matcher_start : nullptr);
    if (!rejection.rejected()) {
      fr.status = TrackingStatus::Tracked;
      return;
    }
    const Isometry3d last_motion = motion.lastMotion();
    const double extrapolated =
        p.tracking.recovery_gap_rotation
            ? std::max(0.0, rotationAngle((T_world_current.inverse() * T_guess).linear()) -
                                rotationAngle(last_motion.linear()))
            : 0.0;
    RecoveryInput in{source,      T_guess, local_map.target(), keyframes.back(), keyframes.size(),
                     last_motion, inl_ref, extrapolated};
    in.T_last = T_world_current;
    in.steps = motion.steps(fr.timestamp, p.tracking.use_timestamps);
    in.last_bridged = !frames.empty() && frames.back().status == TrackingStatus::Bridged;
    in.all_keyframes = &keyframes;
    in.old_keyframes_end = keyframes.size() > p.local_map.keyframes
                               ? keyframes.size() - p.local_map.keyframes
                               : 0;
    in.map_voxel = p.local_map.voxel;
    recovery.recover(in, rejection, fr, times);
    // After a gap the view overlaps the local map less than the frames before it did: the
    // frames after it are judged against the recovered frame's fit, not the old one.
    if (fr.status == TrackingStatus::Recovered && recovery.takenBy() == "gap_paths") {
      tracker.restartRecentInliers(fr.match.inlier_ratio);
      if (auto earlier = recovery.takeRecoveryMap()) local_map.adopt(std::move(earlier));
    }
  }

  /// The scan matcher's registration of the sweep against the last keyframe (world frame), from
  /// the keyframe's pose: a start for the tracker's start search when there is no motion prior.
  std::optional<Isometry3d> matcherStart(const PointCloud& source) {
    TimedStage s(times, Stage::StartSearch);
    const Keyframe& kf = keyframes.back();
    const registration::PreparedTarget target = matcher->prepare(kf.cloud);
    const registration::MatchResult r = matcher->match(source, target, Isometry3d::Identity());
    if (!r.T_target_source.matrix().allFinite()) return std::nullopt;
    return kf.T_world_sensor * r.T_target_source;
  }

  /// After the frame's pose T: a jump the recovery confirmed moves the sweep before; a recovery
  /// beyond what tracking may correct is a jump (lost sweeps): the velocity before it still
  /// holds, so the history moves with the correction instead of absorbing it. (Before there is a
  /// velocity the guess is the last pose, and the correction is the motion itself.)
  void correctMotion(const Isometry3d& T_guess, const Isometry3d& T, TrackingStatus status) {
    const bool jumped_before = jumped_last_frame;
    jumped_last_frame = false;
    if (const std::optional<JumpCandidate> jump = recovery.takeConfirmedJump()) {
      applyConfirmedJump(*jump);
    } else if (status == TrackingStatus::Recovered && motion.count() >= 2) {
      const Isometry3d d = T_guess.inverse() * T;
      if (d.translation().norm() > p.tracking.max_correction ||
          rotationAngle(d.linear()) > p.tracking.max_correction_rotation) {
        jumped_last_frame = true;
        // A second jump in a row: the velocity is wrong; the update below re-estimates it.
        if (!(jumped_before && p.tracking.recovery_repeated_jump_is_velocity))
          motion.applyCorrection(T * T_guess.inverse());
      }
    }
  }

  /// The sweep before this one, bridged with the constant-velocity guess, had a registration
  /// that this sweep's confirmed: it moves there, and the motion model restarts from it (its
  /// bridged pose would turn the jump into a velocity).
  void applyConfirmedJump(const JumpCandidate& jump) {
    FrameRecord& prev = frames.back();
    if (prev.status == TrackingStatus::Bridged && prev.keyframe == keyframes.back().id) {
      prev.T_keyframe_frame = keyframes.back().T_world_sensor.inverse() * jump.T_world_sensor;
      prev.status = TrackingStatus::Recovered;
      --stats.bridged;
      ++stats.recovered;
    }
    travelled += (T_world_current.inverse() * jump.T_world_sensor).translation().norm();
    T_world_current = jump.T_world_sensor;
    motion.reset();
    motion.update(jump.T_world_sensor, prev.timestamp);
  }

  /// Counts the frame's status and warns about recovered and bridged frames.
  void count(const FrameResult& fr) {
    switch (fr.status) {
      case TrackingStatus::Tracked:
        ++stats.tracked;
        bridge_run = 0;
        break;
      case TrackingStatus::Recovered:
        ++stats.recovered;
        bridge_run = 0;
        OBM_LOG_WARN_THROTTLE(
            kLog, 2.0,
            "frame " << fr.index << ": recovered (" << fr.reason << ")");
        break;
      default:
        ++stats.bridged;
        ++bridge_run;
        OBM_LOG_WARN_THROTTLE(kLog, 2.0,
                              "frame " << fr.index << ": bridged with the constant-velocity guess ("
                                       << fr.reason << ")");
        break;
    }
  }

  /// The local map no longer explains the sweeps: start a new one here, joined to the old by a
  /// weak constant-velocity edge (loop closures may tie the pieces together later).
  void restartLocalMap(FrameResult& fr, double timestamp, const Isometry3d& T,
                       const PointCloud& cropped) {
    OBM_LOG_WARN(kLog, "frame " << fr.index << ": " << bridge_run
                                << " bridged frames in a row; restarting the local map");
    ++stats.restarts;
    local_map.restartAt(keyframes.size());
    tracker.forgetRecentInliers();
    if (p.loop_closure.enabled && p.loop_closure.use_descriptor &&
        p.loop_closure.relocalisation.enabled)
      relocaliser.startPiece(keyframes.size());
    addKeyframe(fr.index, timestamp, T, cropped, nullptr, true);
    fr.keyframe = true;
    fr.restarted = true;
    bridge_run = 0;
  }

  void record(FrameResult& fr, const Isometry3d& T_world_frame) {
    FrameRecord rec;
    rec.timestamp = fr.timestamp;
    rec.status = fr.status;
    if (!keyframes.empty()) {
      rec.keyframe = keyframes.back().id;
      rec.T_keyframe_frame = keyframes.back().T_world_sensor.inverse() * T_world_frame;
    }
    fr.keyframe_id = rec.keyframe;
    fr.T_world_sensor = T_world_frame;
    frames.push_back(rec);
  }

  // ---------------------------------------------------------------------------------------
  /// A new keyframe: its cloud and descriptor, a pose-graph node joined to the previous keyframe
  /// by an odometry edge (a bridge edge after a restart), and the local map rebuilt.
  void addKeyframe(std::size_t frame_index, double timestamp, const Isometry3d& T_world_sensor,
                   const PointCloud& cropped, const registration::MatchResult* match,
                   bool bridged) {
    Keyframe kf;
    kf.id = keyframes.size();
    kf.frame_index = frame_index;
    kf.timestamp = timestamp;
    kf.T_world_sensor = T_world_sensor;
    kf.travelled = travelled;
    kf.bridged = bridged;
    {
      TimedStage s(times, Stage::LocalMap);
      kf.cloud = p.local_map.voxel > 0.0 ? voxelDownsample(cropped, p.local_map.voxel) : cropped;
      kf.cloud.intensity.clear();
      // Colours stay only for coloured ICP's photometric term (memory otherwise).
      if (!(p.tracking.icp.color_weight > 0.0)) kf.cloud.colors.clear();
    }
    if (p.loop_closure.enabled && p.loop_closure.use_descriptor) {
      TimedStage s(times, Stage::LoopSearch);
      kf.descriptor = computeDescriptor(cropped, p.loop_closure.descriptor);
    }
    {
      TimedStage s(times, Stage::Graph);
      optimizer.addNode(static_cast<backend::NodeId>(kf.id), T_world_sensor);
      if (kf.id == 0) {
        optimizer.setFixed(0, true);
      } else {
        const Keyframe& prev = keyframes.back();
        backend::Edge3 e;
        e.from = static_cast<backend::NodeId>(prev.id);
        e.to = static_cast<backend::NodeId>(kf.id);
        e.T_from_to = backend::Pose3::fromIsometry(prev.T_world_sensor.inverse() * T_world_sensor);
        e.information = odometryEdgeInformation(p.tracking, match, bridged);
        e.is_loop = false;
        optimizer.addEdge(e);
      }
    }
    keyframes.push_back(std::move(kf));
    ++stats.keyframes;
    frames_since_keyframe = 0;
    recovery.keyframeAdded();
    local_map.afterKeyframe(keyframes, frames.size(), bridged, times);
    if (p.keyframes.revisit_radius > 0.0 && keyframes.size() > p.local_map.keyframes)
      dropIfRevisit(keyframes[keyframes.size() - 1 - p.local_map.keyframes]);
  }

  /// The keyframes since the restart, relocalised onto the map: moved there (in the front-end and
  /// in the optimiser, whose next solve starts from the moved poses), joined by the verified loop
  /// edges, and the graph optimised; the bridge edge into the piece takes the correction.
  void joinPiece(std::size_t first, const Relocaliser::Join& join) {
    for (std::size_t i = first; i < keyframes.size(); ++i) {
      Keyframe& kf = keyframes[i];
      kf.T_world_sensor = join.T_map_piece * kf.T_world_sensor;
      optimizer.setPose(static_cast<backend::NodeId>(kf.id), kf.T_world_sensor);
    }
    T_world_current = join.T_map_piece * T_world_current;
    motion.applyCorrection(join.T_map_piece);
    {
      TimedStage s(times, Stage::Graph);
      for (const auto& [lc, r] : join.loops) optimizer.addEdge(loopEdge(p.loop_closure, lc, r));
    }
    optimize();
  }

  /// The keyframe that just left the local map drops its cloud when an older keyframe of an
  /// earlier pass, still holding its own, lies within revisit_radius (current estimates).
  void dropIfRevisit(Keyframe& kf) {
    if (kf.dropped) return;
    // A piece not yet relocalised is at an unknown place: its "revisits" are not.
    if (const auto first = relocaliser.pieceStart(); first && kf.id >= *first) return;
    const double r2 = p.keyframes.revisit_radius * p.keyframes.revisit_radius;
    for (std::size_t j = 0; j < kf.id; ++j) {
      const Keyframe& old = keyframes[j];
      if (old.dropped || kf.travelled - old.travelled < p.loop_closure.min_travel) continue;
      if ((old.T_world_sensor.translation() - kf.T_world_sensor.translation()).squaredNorm() > r2)
        continue;
      kf.cloud = PointCloud();
      kf.descriptor = PlaceDescriptor();
      kf.dropped = true;
      ++stats.keyframes_dropped;
      return;
    }
  }

  /// The loop closer searches the newest keyframe; an accepted loop is followed by an
  /// optimisation of the pose graph. Returns how many loops were accepted.
  std::size_t closeLoops() {
    if (const std::optional<std::size_t> first = relocaliser.pieceStart()) {
      if (const auto join = relocaliser.search(keyframes, loops, stats, times)) {
        joinPiece(*first, *join);
        return join->loops.size();
      }
    }
    const std::size_t accepted = loop_closer.search(keyframes, loops, optimizer, stats, times);
    if (accepted > 0) optimize();
    return accepted;
  }

  void optimize() {
    backend::Summary sum;
    {
      TimedStage s(times, Stage::Graph);
      sum = optimizer.optimize();
    }
    ++stats.optimizations;
    if (!sum.usable) {
      OBM_LOG_WARN(kLog, "pose-graph optimisation unusable (" << sum.message
                                                              << "); keeping the odometry poses");
      return;
    }
    OBM_LOG_DEBUG(kLog, "graph optimised: chi2 " << sum.initial_chi2 << " -> " << sum.final_chi2
                                                 << " in " << sum.iterations << " iterations");
    const Isometry3d T_old_last = keyframes.back().T_world_sensor;
    for (Keyframe& kf : keyframes) {
      const Isometry3d T = optimizer.pose(static_cast<backend::NodeId>(kf.id));
      if (T.matrix().allFinite()) kf.T_world_sensor = T;
    }
    // The frames since the newest keyframe move with it; the motion model too.
    const Isometry3d T_new_old = keyframes.back().T_world_sensor * T_old_last.inverse();
    T_world_current = T_new_old * T_world_current;
    motion.applyCorrection(T_new_old);
    // The current map is in the old world: replace it now.
    local_map.rebuild(keyframes, frames.size(), false, times);
  }
};

Frontend::Frontend(const FrontendParams& params) {
  const MatcherChoice choice = chooseMatcher(params);
  if (choice.fell_back)
    OBM_LOG_WARN(kLog, choice.message);
  else
    OBM_LOG_INFO(kLog, choice.message);
  impl_ = std::make_unique<Impl>(params, registration::makeScanMatcher(choice.config));
}

Frontend::Frontend(const FrontendParams& params,
                   std::unique_ptr<registration::ScanMatcher> matcher) {
  OBM_ASSERT(matcher != nullptr, "Frontend: the matcher must not be null");
  impl_ = std::make_unique<Impl>(params, std::move(matcher));
}

Frontend::~Frontend() = default;

FrameResult Frontend::process(const PointCloud& sweep) {
  return impl_->process(sweep);
}

void Frontend::finish() {
  impl_->finished = true;
}

std::vector<Isometry3d> Frontend::trajectory() const {
  std::vector<Isometry3d> out;
  out.reserve(impl_->frames.size());
  for (const FrameRecord& f : impl_->frames) {
    if (impl_->keyframes.empty())
      out.push_back(Isometry3d::Identity());
    else
      out.push_back(impl_->keyframes[f.keyframe].T_world_sensor * f.T_keyframe_frame);
  }
  return out;
}

std::vector<double> Frontend::timestamps() const {
  std::vector<double> out;
  out.reserve(impl_->frames.size());
  for (const FrameRecord& f : impl_->frames) out.push_back(f.timestamp);
  return out;
}

std::vector<TrackingStatus> Frontend::statuses() const {
  std::vector<TrackingStatus> out;
  out.reserve(impl_->frames.size());
  for (const FrameRecord& f : impl_->frames) out.push_back(f.status);
  return out;
}

std::vector<std::size_t> Frontend::frameKeyframes() const {
  std::vector<std::size_t> out;
  out.reserve(impl_->frames.size());
  for (const FrameRecord& f : impl_->frames) out.push_back(f.keyframe);
  return out;
}

const std::vector<Keyframe>& Frontend::keyframes() const {
  return impl_->keyframes;
}
const std::vector<LoopClosure>& Frontend::loops() const {
  return impl_->loops;
}
backend::PoseGraph Frontend::graph() const {
  return impl_->optimizer.graph();
}
const FrontendStats& Frontend::stats() const {
  return impl_->stats;
}
const StageTimes& Frontend::times() const {
  return impl_->times;
}
std::string Frontend::matcherName() const {
  return impl_->matcher->name();
}
const FrontendParams& Frontend::params() const {
  return impl_->p;
}

}  // namespace obm::frontend
