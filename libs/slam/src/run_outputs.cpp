#include "run_outputs.hpp"

#include <cmath>
#include <iomanip>
#include <map>
#include <sstream>
#include <thread>

#include "obm/core/csv.hpp"
#include "obm/eval/trajectory_metrics.hpp"
#include "obm/registration/confidence.hpp"

namespace obm::slam {

nlohmann::json jsonNumber(double v) {
  return std::isfinite(v) ? nlohmann::json(v) : nlohmann::json();
}

FrameRow frameRow(const frontend::FrameResult& r) {
  return {r.match.quality,
          r.match.inlier_ratio,
          r.match.rmse,
          r.match.conditioning,
          registration::weakestTranslationSigma(r.match.information),
          r.preprocess.points_in,
          r.preprocess.points_out,
          r.match.start,
          r.reason};
}

std::string framesCsv(const frontend::Frontend& fe, const std::vector<Isometry3d>& traj,
                      const std::vector<double>& stamps, const std::vector<FrameRow>& rows) {
  const auto statuses = fe.statuses();
  const auto kf_of = fe.frameKeyframes();
  std::ostringstream os;
  os << "# frame,timestamp,status,keyframe_id,is_keyframe,quality,inlier_ratio,rmse_m,"
        "points_in,points_used,conditioning,weakest_sigma_m,start,reason\n";
  std::vector<bool> is_kf(traj.size(), false);
  for (const auto& kf : fe.keyframes())
    if (kf.frame_index < is_kf.size()) is_kf[kf.frame_index] = true;
  os << std::setprecision(17);
  for (std::size_t i = 0; i < traj.size(); ++i)
    os << i << ',' << stamps[i] << ',' << frontend::toString(statuses[i]) << ',' << kf_of[i] << ','
       << (is_kf[i] ? 1 : 0) << ',' << std::setprecision(6) << rows[i].quality << ','
       << rows[i].inlier_ratio << ',' << rows[i].rmse << ',' << rows[i].points_in << ','
       << rows[i].points_used << ',' << rows[i].conditioning << ',' << rows[i].weakest_sigma
       << ',' << registration::toString(rows[i].start) << ",\"" << csvQuoted(rows[i].reason)
       << '"' << std::setprecision(17) << '\n';
  return os.str();
}

std::string loopsCsv(const frontend::Frontend& fe) {
  std::ostringstream os;
  os << "# from_keyframe,to_keyframe,from_frame,to_frame,accepted,quality,inlier_ratio,"
        "descriptor_distance,correction_m,tx,ty,tz,qx,qy,qz,qw,relocalisation,start,reason\n";
  for (const auto& lc : fe.loops()) {
    const Eigen::Quaterniond q(lc.T_from_to.linear());
    const Eigen::Vector3d t = lc.T_from_to.translation();
    os << lc.from << ',' << lc.to << ',' << fe.keyframes()[lc.from].frame_index << ','
       << fe.keyframes()[lc.to].frame_index << ',' << (lc.accepted ? 1 : 0) << ',' << lc.quality
       << ',' << lc.inlier_ratio << ',' << lc.descriptor_distance << ',' << lc.correction << ','
       << t.x() << ',' << t.y() << ',' << t.z() << ',' << q.x() << ',' << q.y() << ',' << q.z()
       << ',' << q.w() << ',' << (lc.relocalisation ? 1 : 0) << ','
       << registration::toString(lc.start) << ",\"" << csvQuoted(lc.reason)
       << "\"\n";
  }
  return os.str();
}

AlignedGroundTruth alignGroundTruth(const std::vector<Isometry3d>& traj,
                                    const io::FrameGroundTruth& gt) {
  AlignedGroundTruth a;
  eval::PoseList est, ref;
  for (std::size_t i = 0; i < traj.size() && i < gt.T_world_body.size(); ++i)
    if (gt.T_world_body[i]) {
      est.push_back(traj[i]);
      ref.push_back(*gt.T_world_body[i]);
    }
  if (est.size() < 3) return a;
  const auto ate = eval::absoluteTrajectoryError(ref, est, eval::Alignment::SE3);
  Isometry3d T_gt_est = Isometry3d::Identity();
  T_gt_est.linear() = ate.alignment.R;
  T_gt_est.translation() = ate.alignment.t;
  for (const auto& T : ref) a.T_world_body.push_back(T_gt_est.inverse() * T);
  a.ate_errors = ate.errors;
  double d = 0.0;
  for (std::size_t i = 0; i < ref.size(); ++i) {
    if (i > 0) d += (ref[i].translation() - ref[i - 1].translation()).norm();
    a.distance_m.push_back(d);
  }
  return a;
}

nlohmann::json metricsJson(const RunSummary& sum, const io::FrameGroundTruth& gt,
                           std::size_t read_errors, const std::string& input) {
  nlohmann::json j;
  const TrajectoryMetrics m = sum.metrics.value_or(TrajectoryMetrics{});
  const bool have = sum.metrics.has_value();
  const auto& st = sum.stats;
  j["t_err_percent"] = have ? jsonNumber(m.t_err_percent) : nlohmann::json();
  j["r_err_deg_per_100m"] = have ? jsonNumber(m.r_err_deg_per_100m) : nlohmann::json();
  j["ate_rmse_m"] = have ? jsonNumber(m.ate_rmse_m) : nlohmann::json();
  j["ate_mean_m"] = have ? jsonNumber(m.ate_mean_m) : nlohmann::json();
  j["ate_max_m"] = have ? jsonNumber(m.ate_max_m) : nlohmann::json();
  j["rpe_trans_rmse_m"] = have ? jsonNumber(m.rpe_trans_rmse_m) : nlohmann::json();
  j["rpe_rot_rmse_deg"] = have ? jsonNumber(m.rpe_rot_rmse_deg) : nlohmann::json();
  j["kitti_segments"] = m.kitti_segments;
  j["frames_evaluated"] = m.frames_evaluated;
  j["ground_truth_length_m"] = have ? jsonNumber(m.length_m) : nlohmann::json();
  j["evaluation_frame"] = have ? nlohmann::json(m.frame) : nlohmann::json();
  j["ground_truth"] = gt.path.empty() ? nlohmann::json() : nlohmann::json(gt.path);
  j["loops_accepted"] = st.loops_accepted;
  j["loops_rejected"] = st.loops_rejected;
  j["loops_checked"] = m.loops_checked;
  j["loops_wrong"] = m.loops_wrong;
  j["loop_error_max_m"] = have ? jsonNumber(m.loop_error_max_m) : nlohmann::json();
  j["loop_error_max_deg"] = have ? jsonNumber(m.loop_error_max_deg) : nlohmann::json();
  j["loop_candidates"] = st.loop_candidates;
  auto site = [](const MatcherSite& m) {
    nlohmann::json o;
    o["results"] = m.results;
    o["from_network"] = m.network;
    o["taken"] = m.taken;
    o["taken_from_network"] = m.taken_network;
    o["checked"] = m.checked;
    o["wrong"] = m.wrong;
    o["wrong_from_network"] = m.wrong_network;
    return o;
  };
  j["matcher_ledger"] = {{"loop_verification", site(sum.ledger.loop_verification)},
                         {"recovery", site(sum.ledger.recovery)}};
  j["frames"] = sum.frames;
  j["keyframes"] = st.keyframes;
  j["keyframes_dropped"] = st.keyframes_dropped;
  j["relocalisations"] = st.relocalisations;
  j["frames_tracked"] = st.tracked;
  j["frames_recovered"] = st.recovered;
  j["frames_bridged"] = st.bridged;
  j["map_restarts"] = st.restarts;
  j["unusable_sweeps"] = st.empty_sweeps;
  j["read_errors"] = read_errors;
  j["matcher"] = sum.matcher;
  j["input"] = input;
  j["input_kind"] = sum.input_kind;
  j["interrupted"] = sum.interrupted;
  return j;
}

nlohmann::json timingJson(const RunSummary& sum, const RunTimes& times) {
  const std::size_t n = sum.frames;
  nlohmann::json j;
  j["frames"] = n;
  j["keyframes"] = sum.stats.keyframes;
  j["wall_s"] = sum.wall_s;
  j["frames_per_second"] = sum.frames_per_second;
  j["processing_s"] = times.processing_s;
  j["processing_frames_per_second"] =
      times.processing_s > 0 ? static_cast<double>(n) / times.processing_s : 0.0;
  j["cpu_s"] = times.cpu_s;
  nlohmann::json stages;
  for (const auto& [stage, ms] : sum.stages_ms) stages[stage] = ms;
  j["stages_ms"] = stages;
  nlohmann::json per_frame;
  for (const auto& [stage, ms] : sum.stages_ms)
    per_frame[stage] = n > 0 ? ms / static_cast<double>(n) : 0.0;
  j["per_frame_ms"] = per_frame;
  j["map_rebuilt"] = sum.map_rebuilt;
  j["map_max_keyframe_shift_m"] = times.map_shift_m;
  j["map_max_keyframe_shift_deg"] = times.map_shift_deg;
  j["hardware_threads"] = std::thread::hardware_concurrency();
  return j;
}

RunReport runReport(const frontend::Frontend& fe, const std::vector<Isometry3d>& traj,
                    const AlignedGroundTruth& gt, const Isometry3d& T_up_sensor,
                    const std::string& title, nlohmann::json metrics, nlohmann::json timing,
                    std::vector<std::string> pictures) {
  RunReport rep;
  rep.title = title;
  auto xy = [&](const Isometry3d& T) {
    const Eigen::Vector3d p = T_up_sensor * T.translation();
    return Eigen::Vector2d(p.x(), p.y());
  };
  for (const auto& T : traj) rep.estimate.push_back(xy(T));
  for (const auto& T : gt.T_world_body) rep.reference.push_back(xy(T));
  for (const auto& lc : fe.loops())
    if (lc.accepted)
      rep.loops.emplace_back(fe.keyframes()[lc.from].frame_index,
                             fe.keyframes()[lc.to].frame_index);
  rep.error_m = gt.ate_errors;
  rep.distance_m = gt.distance_m;
  rep.metrics = std::move(metrics);
  rep.timing = std::move(timing);
  std::map<std::string, int> counts;
  for (const auto s : fe.statuses()) ++counts[frontend::toString(s)];
  for (const auto& [k, c] : counts) rep.status_counts.emplace_back(k, c);
  rep.pictures = std::move(pictures);
  return rep;
}

}  // namespace obm::slam
