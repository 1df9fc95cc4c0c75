#include "obm/frontend/stages.hpp"
#include "obm/slam/mapping_app.hpp"

#include <cmath>
#include <ctime>
#include <filesystem>
#include <future>
#include <iomanip>
#include <limits>
#include <nlohmann/json.hpp>
#include <sstream>
#include <thread>

#include "map_worker.hpp"
#include "mrpt_outputs.hpp"
#include "run_outputs.hpp"
#include "run_report.hpp"
#include "obm/backend/graph_io.hpp"
#include "obm/core/atomic_file.hpp"
#include "obm/core/errors.hpp"
#include "obm/core/log.hpp"
#include "obm/core/progress.hpp"
#include "obm/core/timer.hpp"
#include "obm/eval/kitti_odometry.hpp"
#include "obm/eval/trajectory_metrics.hpp"
#include "obm/io/frame_stream.hpp"
#include "obm/io/kitti.hpp"
#include "obm/io/trajectory.hpp"
#include "obm/registration/confidence.hpp"
#include "top_view_png.hpp"

namespace fs = std::filesystem;

namespace obm::slam {

namespace {

/// The reader's options for the `input:` parameters; `ground_truth` overrides the layout's own.
io::FrameStreamOptions streamOptions(const InputParams& p, const std::string& ground_truth) {
  io::FrameStreamOptions o;
  o.ground_truth = ground_truth;
  o.rgbd_stride = p.rgbd_stride;
  o.rgbd_color = p.rgbd_color;
  o.rgbd_edge_jump = p.rgbd_edge_jump;
  o.depth_min = p.depth_min;
  o.depth_max = p.depth_max;
  o.max_time_difference = p.max_time_difference;
  o.sensor_label = p.sensor_label;
  o.velodyne_min_range = p.velodyne_min_range;
  o.log_component = "obm-map";
  return o;
}

constexpr const char* kLog = "obm-map";
constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

double processCpuSeconds() {
  timespec ts{};
  clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &ts);
  return static_cast<double>(ts.tv_sec) + 1e-9 * static_cast<double>(ts.tv_nsec);
}

/// Fails early (before any frame is processed) when the output folder cannot be written.
void checkWritable(const std::string& dir) {
  ensureDirectory(dir);
  const std::string probe = (fs::path(dir) / ".obm-map-write-test").string();
  try {
    writeTextAtomically(probe, "");
  } catch (const Error& e) {
    throw IoError("output folder '" + dir + "' cannot be written: " + e.what());
  }
  std::error_code ec;
  fs::remove(probe, ec);
}

TrajectoryMetrics computeMetrics(const std::vector<Isometry3d>& est_all,
                                 const io::FrameGroundTruth& gt, const io::KittiCalib* calib) {
  TrajectoryMetrics m;
  eval::PoseList est, ref;
  for (std::size_t i = 0; i < est_all.size() && i < gt.T_world_body.size(); ++i) {
    if (!gt.T_world_body[i]) continue;
    est.push_back(est_all[i]);
    ref.push_back(*gt.T_world_body[i]);
  }
  m.frames_evaluated = est.size();
  m.frame = "sensor";
  if (calib) {
    // The devkit's convention: camera-0 poses (T_cam = Tr·T_velo·Tr⁻¹), as in poses.txt.
    est = io::lidarToCameraPoses(est, calib->T_cam0_velo);
    ref = io::lidarToCameraPoses(ref, calib->T_cam0_velo);
    m.frame = "camera0";
  }
  const auto dist = eval::trajectoryDistances(ref);
  m.length_m = dist.empty() ? 0.0 : dist.back();
  m.t_err_percent = m.r_err_deg_per_100m = kNaN;
  m.ate_rmse_m = m.ate_mean_m = m.ate_max_m = kNaN;
  m.rpe_trans_rmse_m = m.rpe_rot_rmse_deg = kNaN;
  if (est.size() < 3) return m;
  const auto kitti = eval::evaluateKittiOdometry(ref, est);
  m.kitti_segments = kitti.n_segments;
  if (kitti.n_segments > 0) {
    m.t_err_percent = kitti.t_err_percent;
    m.r_err_deg_per_100m = kitti.r_err_deg_per_100m;
  }
  const auto ate = eval::absoluteTrajectoryError(ref, est, eval::Alignment::SE3);
  m.ate_rmse_m = ate.rmse;
  m.ate_mean_m = ate.mean;
  m.ate_max_m = ate.max;
  const auto rpe = eval::relativePoseError(ref, est);
  if (rpe.n_pairs > 0) {
    m.rpe_trans_rmse_m = rpe.trans_rmse;
    m.rpe_rot_rmse_deg = rpe.rot_rmse_deg;
  }
  return m;
}

std::string fmt(double v, int precision = 3) {
  if (!std::isfinite(v)) return "n/a";
  std::ostringstream os;
  os << std::fixed << std::setprecision(precision) << v;
  return os.str();
}

/// Reads the next frame in a worker thread while the current one is processed, so that decoding
/// (a depth and a colour PNG, a KITTI scan) overlaps with tracking instead of adding to it. The
/// frames and their order are the source's: only one thread uses the source at a time.
class FramePrefetcher {
 public:
  explicit FramePrefetcher(io::FrameStream& source) : source_(source) {}
  ~FramePrefetcher() { wait(); }
  /// Waits for a pending read (its frame is dropped): the source is the caller's again.
  void wait() {
    if (pending_.valid()) pending_.wait();
  }
  FramePrefetcher(const FramePrefetcher&) = delete;
  FramePrefetcher& operator=(const FramePrefetcher&) = delete;

  /// Starts reading the next frame (no-op when a read is pending).
  void prefetch() {
    if (pending_.valid()) return;
    pending_ = std::async(std::launch::async, [this] {
      std::pair<bool, PointCloud> r;
      r.first = source_.next(r.second);
      return r;
    });
  }
  /// The next frame (waits for the pending read, or reads it now); false at the end. A read
  /// error is rethrown here.
  bool next(PointCloud& cloud) {
    prefetch();
    auto r = pending_.get();
    if (r.first) cloud = std::move(r.second);
    return r.first;
  }

 private:
  io::FrameStream& source_;
  std::future<std::pair<bool, PointCloud>> pending_;
};

}  // namespace

void scoreLoops(const std::vector<frontend::LoopClosure>& loops,
                const std::vector<std::size_t>& keyframe_frames,
                const std::vector<std::optional<Isometry3d>>& T_world_body, TrajectoryMetrics& m) {
  m.loops_checked = m.loops_wrong = 0;
  m.loop_error_max_m = m.loop_error_max_deg = kNaN;
  for (const auto& lc : loops) {
    if (!lc.accepted || lc.from >= keyframe_frames.size() || lc.to >= keyframe_frames.size())
      continue;
    const std::size_t a = keyframe_frames[lc.from], b = keyframe_frames[lc.to];
    if (a >= T_world_body.size() || b >= T_world_body.size() || !T_world_body[a] ||
        !T_world_body[b])
      continue;
    const Isometry3d T_from_to_gt = T_world_body[a]->inverse() * *T_world_body[b];
    const Isometry3d E = T_from_to_gt.inverse() * lc.T_from_to;
    const double e_t = E.translation().norm();
    const double e_r = rotationAngle(E.linear()) * kRadToDeg;
    if (m.loops_checked == 0) m.loop_error_max_m = m.loop_error_max_deg = 0.0;
    ++m.loops_checked;
    m.loop_error_max_m = std::max(m.loop_error_max_m, e_t);
    m.loop_error_max_deg = std::max(m.loop_error_max_deg, e_r);
    if (e_t > kWrongLoopTranslation || e_r > kWrongLoopRotationDeg) ++m.loops_wrong;
  }
}

namespace {
/// Off the truth by more than the wrong-loop bounds (kWrongLoopTranslation, kWrongLoopRotationDeg).
bool offTruth(const Isometry3d& T_measured, const Isometry3d& T_truth) {
  const Isometry3d E = T_truth.inverse() * T_measured;
  return E.translation().norm() > kWrongLoopTranslation ||
         rotationAngle(E.linear()) * kRadToDeg > kWrongLoopRotationDeg;
}
}  // namespace

MatcherLedger matcherLedger(const std::vector<frontend::LoopClosure>& loops,
                            const std::vector<std::size_t>& keyframe_frames,
                            const std::vector<frontend::TrackingStatus>& statuses,
                            const std::vector<registration::MatchStart>& starts,
                            const std::vector<Isometry3d>& traj,
                            const std::vector<std::optional<Isometry3d>>& T_world_body) {
  MatcherLedger ledger;
  auto truth = [&](std::size_t frame) -> const std::optional<Isometry3d>* {
    return frame < T_world_body.size() && T_world_body[frame] ? &T_world_body[frame] : nullptr;
  };
  auto count = [](MatcherSite& site, bool network, bool taken, std::optional<bool> wrong) {
    ++site.results;
    site.network += network;
    if (!taken) return;
    ++site.taken;
    site.taken_network += network;
    if (!wrong) return;
    ++site.checked;
    site.wrong += *wrong;
    site.wrong_network += *wrong && network;
  };
  for (const auto& lc : loops) {
    std::optional<bool> wrong;
    if (lc.accepted && lc.from < keyframe_frames.size() && lc.to < keyframe_frames.size()) {
      const auto* a = truth(keyframe_frames[lc.from]);
      const auto* b = truth(keyframe_frames[lc.to]);
      if (a && b) wrong = offTruth(lc.T_from_to, (*a)->inverse() * **b);
    }
    count(ledger.loop_verification, registration::fromNetwork(lc.start), lc.accepted, wrong);
  }
  for (std::size_t i = 1; i < statuses.size() && i < starts.size() && i < traj.size(); ++i) {
    if (statuses[i] != frontend::TrackingStatus::Recovered) continue;
    std::optional<bool> wrong;
    const auto* a = truth(i - 1);
    const auto* b = truth(i);
    if (a && b) wrong = offTruth(traj[i - 1].inverse() * traj[i], (*a)->inverse() * **b);
    count(ledger.recovery, registration::fromNetwork(starts[i]), true, wrong);
  }
  return ledger;
}

MappingApp::MappingApp(SlamConfig config, MappingAppOptions options)
    : config_(std::move(config)), options_(std::move(options)) {
  if (options_.input.empty()) throw ConfigError("obm-map: the input is empty");
  if (options_.out_dir.empty()) throw ConfigError("obm-map: the output folder is empty");
  config_.frontend.validate();
  config_.mapping.validate();
  config_.input.validate();
  config_.output.validate();
}

MappingApp::~MappingApp() = default;

RunSummary MappingApp::run() {
  Timer wall;
  const double cpu0 = processCpuSeconds();
  RunSummary sum;
  const fs::path out(options_.out_dir);
  const SlamConfig& cfg = config_;

  // Everything that can be checked is checked before the first frame: the input and the model
  // first, so that a run failing on them does not leave an empty output folder behind.
  auto source = io::FrameStream::open(options_.input, streamOptions(cfg.input, options_.ground_truth));
  sum.input_kind = io::toString(source->kind());
  sum.frames_total = source->size();
  if (options_.max_frames > 0 && sum.frames_total > 0)
    sum.frames_total = std::min(sum.frames_total, options_.max_frames);
  frontend::Frontend fe(cfg.frontend);
  sum.matcher = fe.matcherName();
  checkWritable(options_.out_dir);

  std::unique_ptr<detail::MapWorker> mapper;
  const double map_voxel =
      cfg.output.map_cloud_voxel > 0.0 ? cfg.output.map_cloud_voxel : 0.5 * cfg.mapping.resolution;
  if (cfg.output.map) mapper = std::make_unique<detail::MapWorker>(cfg.mapping, map_voxel);

  StageTimes app_times;
  ProgressBar bar(sum.frames_total, "obm-map", "frames");
  bar.setEnabled(options_.progress);
  Timer since_start;
  std::size_t n = 0;
  Isometry3d T_up_sensor = Isometry3d::Identity();
  std::vector<FrameRow> frame_rows;
  const io::KittiCalib* calib = source->kittiCalib();
  // The two trajectories as the run ends writes them (every frame, the current estimates).
  auto writeTrajectories = [&](const std::vector<Isometry3d>& traj,
                               const std::vector<double>& stamps, bool record) {
    const std::string tum = (out / "trajectory_tum.txt").string(),
                      kitti = (out / "trajectory_kitti.txt").string();
    io::writeTumTrajectory(tum, io::stampPoses(traj, stamps));
    io::writeKittiTrajectory(kitti,
                             calib ? io::lidarToCameraPoses(traj, calib->T_cam0_velo) : traj);
    if (record) {
      sum.files.push_back(tum);
      sum.files.push_back(kitti);
    }
  };
  Timer since_save;
  FramePrefetcher reader(*source);
  while (options_.max_frames == 0 || n < options_.max_frames) {
    if (options_.cancel && options_.cancel->load()) {
      sum.interrupted = true;
      break;
    }
    PointCloud cloud;
    {
      frontend::TimedStage s(app_times, frontend::Stage::Read);  // the wait for the frame read meanwhile
      if (!reader.next(cloud)) break;
    }
    if (n == 0) T_up_sensor = source->T_up_sensor();
    // The following frame is read while this one is processed (unless it will not be used).
    if (options_.max_frames == 0 || n + 1 < options_.max_frames) reader.prefetch();
    const frontend::FrameResult r = fe.process(cloud);
    frame_rows.push_back(frameRow(r));
    ++n;
    if (r.keyframe && mapper && r.keyframe_id % cfg.output.map_every == 0) {
      frontend::TimedStage s(app_times, frontend::Stage::OctomapQueue);
      mapper->push(r.keyframe_id, std::move(cloud), T_up_sensor * r.T_world_sensor);
    }
    const auto& st = fe.stats();
    std::ostringstream status;
    status << "kf " << st.keyframes << " loops " << st.loops_accepted;
    if (st.bridged > 0) status << " bridged " << st.bridged;
    bar.update(n, status.str());
    if (cfg.output.autosave_s > 0.0 && since_save.seconds() >= cfg.output.autosave_s) {
      frontend::TimedStage s(app_times, frontend::Stage::Autosave);  // the folder exists: checkWritable made it
      writeTrajectories(fe.trajectory(), fe.timestamps(), false);
      since_save.reset();
    }
  }
  reader.wait();  // a read started before a cancel
  fe.finish();
  const auto& st = fe.stats();
  bar.finish("kf " + std::to_string(st.keyframes) + " loops " + std::to_string(st.loops_accepted));
  sum.frames = n;
  sum.stats = st;
  const double process_s = since_start.seconds();
  if (sum.interrupted)
    OBM_LOG_WARN(kLog, "interrupted after " << n << " frames; writing what was processed");
  if (source->readErrors() > 0)
    OBM_LOG_WARN(kLog, source->readErrors() << " frame(s) could not be read and were bridged");

  // --- outputs -----------------------------------------------------------------------------
  Timer output_timer;
  const std::vector<Isometry3d> traj = fe.trajectory();
  const std::vector<double> stamps = fe.timestamps();
  auto file = [&](const std::string& name) {
    const std::string p = (out / name).string();
    sum.files.push_back(p);
    return p;
  };
  writeTrajectories(traj, stamps, true);
  {
    io::Trajectory kfs;
    for (const auto& kf : fe.keyframes()) kfs.push_back({kf.timestamp, kf.T_world_sensor});
    io::writeTumTrajectory(file("keyframes_tum.txt"), kfs);
  }
  backend::writeG2o(fe.graph(), file("graph.g2o"));
  writeTextAtomically(file("frames.csv"), framesCsv(fe, traj, stamps, frame_rows));
  writeTextAtomically(file("loops.csv"), loopsCsv(fe));

  // Ground truth and metrics.
  const io::FrameGroundTruth gt = source->groundTruth(stamps, cfg.input.max_time_difference);
  sum.ground_truth = gt.path;
  AlignedGroundTruth gt_aligned;  // for the pictures
  std::vector<std::size_t> keyframe_frames;
  for (const auto& kf : fe.keyframes()) keyframe_frames.push_back(kf.frame_index);
  if (!gt.path.empty()) {
    sum.metrics = computeMetrics(traj, gt, calib);
    scoreLoops(fe.loops(), keyframe_frames, gt.T_world_body, *sum.metrics);
    gt_aligned = alignGroundTruth(traj, gt);
  }
  {
    std::vector<registration::MatchStart> starts;
    for (const auto& row : frame_rows) starts.push_back(row.start);
    sum.ledger = matcherLedger(fe.loops(), keyframe_frames, fe.statuses(), starts, traj,
                               gt.T_world_body);
  }
  const std::vector<Isometry3d>& gt_plot = gt_aligned.T_world_body;
  const nlohmann::json metrics_json = metricsJson(sum, gt, source->readErrors(), options_.input);
  writeTextAtomically(file("metrics.json"), metrics_json.dump(2) + "\n");

  // Map.
  double map_shift = 0.0, map_shift_deg = 0.0;
  if (mapper) {
    std::map<std::size_t, Isometry3d> final_poses;
    for (const auto& kf : fe.keyframes()) final_poses[kf.id] = T_up_sensor * kf.T_world_sensor;
    sum.map_rebuilt = mapper->finish(final_poses, cfg.output.map_rebuild_translation,
                                     cfg.output.map_rebuild_rotation);
    map_shift = mapper->maxShift();
    map_shift_deg = mapper->maxShiftRotation() * kRadToDeg;
    if (sum.map_rebuilt)
      OBM_LOG_INFO(kLog, "OctoMap rebuilt at the optimised keyframe poses (a keyframe moved "
                             << map_shift << " m / " << map_shift_deg
                             << " deg after it was integrated)");
    Timer t;
    if (mapper->inserted() > 0) {
      mapper->map().writeBinary(file("map.bt"));
      mapper->map().writeFull(file("map.ot"));
      if (cfg.output.pictures) {
        mapping::TopViewOptions tv;
        tv.max_pixels = cfg.output.png_max_pixels;
        tv.z_max = cfg.output.png_z_max;
        writeTopViewPng(mapper->map(), file("map_topview.png"), tv);
      }
    } else {
      OBM_LOG_WARN(kLog, "no keyframe was integrated: no map written");
    }
    frontend::addStageTime(app_times, frontend::Stage::Octomap, mapper->busyMs() + t.ms());
  }
  if (cfg.output.pictures && !traj.empty()) {
    std::vector<std::pair<std::size_t, std::size_t>> loop_frames;
    for (const auto& lc : fe.loops())
      if (lc.accepted)
        loop_frames.emplace_back(fe.keyframes()[lc.from].frame_index,
                                 fe.keyframes()[lc.to].frame_index);
    writeTrajectoryPng(file("trajectory_topview.png"), traj, gt_plot, loop_frames, T_up_sensor,
                       cfg.output.png_max_pixels);
  }
  if (cfg.output.mrpt && !traj.empty())
    writeMrptOutputs(fe, traj, stamps, gt_plot, T_up_sensor, cfg.output.scene_voxel, file);
  frontend::addStageTime(app_times, frontend::Stage::Output, output_timer.ms());

  // Timing (written last so it covers everything but itself).
  sum.wall_s = wall.seconds();
  sum.frames_per_second = sum.wall_s > 0.0 ? static_cast<double>(n) / sum.wall_s : 0.0;
  for (const StageTimes* times : {&fe.times(), static_cast<const StageTimes*>(&app_times)})
    for (const auto& [stage, e] : times->entries()) sum.stages_ms[stage] += e.total_ms;
  for (const char* s : {"obmnet", "icp", "graph", "octomap"}) sum.stages_ms.emplace(s, 0.0);
  RunTimes times;
  times.processing_s = process_s;
  times.cpu_s = processCpuSeconds() - cpu0;
  times.map_shift_m = map_shift;
  times.map_shift_deg = map_shift_deg;
  const nlohmann::json timing_json = timingJson(sum, times);
  writeTextAtomically(file("timing.json"), timing_json.dump(2) + "\n");
  // The page of the run (after timing.json, which it shows): report.html and the SVG top view.
  if (cfg.output.pictures && !traj.empty()) {
    std::vector<std::string> pictures;
    for (const char* png : {"trajectory_topview.png", "map_topview.png"})
      if (fs::exists(out / png)) pictures.emplace_back(png);
    const RunReport rep = runReport(fe, traj, gt_aligned, T_up_sensor, options_.input,
                                    metrics_json, timing_json, std::move(pictures));
    writeTextAtomically(file("trajectory_topview.svg"), trajectorySvg(rep));
    writeTextAtomically(file("report.html"), reportHtml(rep));
  }
  return sum;
}

std::string formatSummary(const RunSummary& s) {
  std::ostringstream os;
  os << "input           " << s.input_kind << ", " << s.frames << " frames"
     << (s.interrupted ? " (interrupted)" : "") << "\n";
  os << "matcher         " << s.matcher << "\n";
  os << "keyframes       " << s.stats.keyframes << "\n";
  os << "frames          " << s.stats.tracked << " tracked, " << s.stats.recovered << " recovered, "
     << s.stats.bridged << " bridged, " << s.stats.restarts << " local-map restarts ("
     << s.stats.relocalisations << " relocalised)\n";
  os << "loop closures   " << s.stats.loops_accepted << " accepted, " << s.stats.loops_rejected
     << " rejected (" << s.stats.loop_searches << " searches)\n";
  if (s.metrics) {
    const auto& m = *s.metrics;
    os << "ground truth    " << s.ground_truth << " (" << m.frames_evaluated << " frames, "
       << fmt(m.length_m, 1) << " m)\n";
    os << "KITTI metric    t_err " << fmt(m.t_err_percent) << " %, r_err "
       << fmt(m.r_err_deg_per_100m, 4) << " deg/100m (" << m.kitti_segments << " segments)\n";
    os << "ATE             rmse " << fmt(m.ate_rmse_m, 4) << " m, mean " << fmt(m.ate_mean_m, 4)
       << " m, max " << fmt(m.ate_max_m, 4) << " m\n";
    os << "RPE (1 frame)   " << fmt(m.rpe_trans_rmse_m, 4) << " m, " << fmt(m.rpe_rot_rmse_deg, 4)
       << " deg\n";
    if (m.loops_checked > 0)
      os << "loops vs truth  " << m.loops_wrong << " of " << m.loops_checked
         << " accepted loops wrong (> " << kWrongLoopTranslation << " m or "
         << kWrongLoopRotationDeg << " deg); largest errors " << fmt(m.loop_error_max_m) << " m, "
         << fmt(m.loop_error_max_deg) << " deg\n";
  } else {
    os << "ground truth    none (no metrics)\n";
  }
  if (s.matcher != "icp") {
    // Where the network's pose was the one refined and taken (the rest started from the guess).
    auto site = [&](const char* what, const MatcherSite& m, const char* taken) {
      os << what << m.results << " results, " << m.network << " from the network's pose; "
         << m.taken << ' ' << taken << ", " << m.taken_network << " from the network's pose";
      if (m.checked > 0)
        os << " (wrong vs truth: " << m.wrong << ", " << m.wrong_network
           << " of them the network's)";
      os << '\n';
    };
    site("network, loops  ", s.ledger.loop_verification, "accepted");
    site("network, recov. ", s.ledger.recovery, "recovered");
  }
  os << "speed           " << fmt(s.frames_per_second, 2) << " frames/s (" << fmt(s.wall_s, 1)
     << " s wall)\n";
  os << "stages [ms]    ";
  for (const auto& [stage, ms] : s.stages_ms) os << " " << stage << " " << fmt(ms, 0);
  os << "\n";
  for (const auto& f : s.files) os << "wrote           " << f << "\n";
  return os.str();
}

}  // namespace obm::slam
