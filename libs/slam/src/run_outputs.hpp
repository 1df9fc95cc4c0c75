#pragma once
// The files obm-map writes after the last frame, one function per file (docs/obm-map.md,
// "Outputs"): the per-frame and per-loop CSVs, metrics.json, timing.json and the run's page. Each
// returns the text (or JSON / report) and MappingApp::run() writes it atomically.
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "obm/core/se3.hpp"
#include "obm/frontend/frontend.hpp"
#include "obm/io/frame_stream.hpp"
#include "obm/slam/mapping_app.hpp"
#include "run_report.hpp"

namespace obm::slam {

/// The per-frame numbers of frames.csv that the front-end does not keep.
struct FrameRow {
  double quality = 0.0, inlier_ratio = 0.0, rmse = 0.0, conditioning = 0.0, weakest_sigma = 0.0;
  std::size_t points_in = 0, points_used = 0;
  registration::MatchStart start = registration::MatchStart::Guess;  ///< of the taken match
  std::string reason;
};
FrameRow frameRow(const frontend::FrameResult& r);

/// frames.csv: one line per frame of `traj` (the front-end's final trajectory).
std::string framesCsv(const frontend::Frontend& fe, const std::vector<Isometry3d>& traj,
                      const std::vector<double>& stamps, const std::vector<FrameRow>& rows);
/// loops.csv: every loop candidate that was verified, accepted or not.
std::string loopsCsv(const frontend::Frontend& fe);

/// The ground truth of the evaluated frames aligned to the estimate (SE(3), as the ATE), for the
/// pictures: the poses in the estimate's world frame, the position error and the distance
/// travelled per evaluated frame. Empty with fewer than three evaluated frames.
struct AlignedGroundTruth {
  std::vector<Isometry3d> T_world_body;
  std::vector<double> ate_errors, distance_m;
};
AlignedGroundTruth alignGroundTruth(const std::vector<Isometry3d>& traj,
                                    const io::FrameGroundTruth& gt);

/// JSON number, or null for NaN / infinity (JSON has no NaN).
nlohmann::json jsonNumber(double v);

/// metrics.json.
nlohmann::json metricsJson(const RunSummary& sum, const io::FrameGroundTruth& gt,
                           std::size_t read_errors, const std::string& input);

/// What timing.json reports besides the stage totals of `sum`.
struct RunTimes {
  double processing_s = 0.0;  ///< the frame loop
  double cpu_s = 0.0;         ///< process CPU time
  double map_shift_m = 0.0, map_shift_deg = 0.0;  ///< largest keyframe move after integration
};
/// timing.json.
nlohmann::json timingJson(const RunSummary& sum, const RunTimes& times);

/// The run's page (report.html, trajectory_topview.svg). `pictures`: PNG files beside it.
RunReport runReport(const frontend::Frontend& fe, const std::vector<Isometry3d>& traj,
                    const AlignedGroundTruth& gt, const Isometry3d& T_up_sensor,
                    const std::string& title, nlohmann::json metrics, nlohmann::json timing,
                    std::vector<std::string> pictures);

}  // namespace obm::slam
