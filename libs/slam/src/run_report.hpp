#pragma once
// The picture and the page of an obm-map run (docs/obm-map.md, "Outputs"): a top-view SVG of the
// trajectory with axes in metres, a scale bar, a legend and the metrics in its title, and
// report.html (that picture, the error over distance, the map's top view and the tables).
#include <Eigen/Core>
#include <nlohmann/json.hpp>
#include <string>
#include <utility>
#include <vector>

namespace obm::slam {

struct RunReport {
  std::string title;                   ///< e.g. the input folder
  std::vector<Eigen::Vector2d> estimate;  ///< top view [m], every frame
  std::vector<Eigen::Vector2d> reference; ///< ground truth aligned to the estimate; may be empty
  std::vector<std::pair<std::size_t, std::size_t>> loops;  ///< accepted loops, frame indices
  std::vector<double> distance_m;      ///< along the ground truth, per evaluated frame
  std::vector<double> error_m;         ///< ATE position error per evaluated frame
  nlohmann::json metrics;              ///< metrics.json
  nlohmann::json timing;               ///< timing.json
  std::vector<std::pair<std::string, int>> status_counts;  ///< frames by status
  std::vector<std::string> pictures;   ///< PNG files beside the page to show (map top view, …)
};

/// The top view as SVG: estimate red, ground truth black, loop edges blue, start green; axes with
/// ticks in metres, a scale bar, a legend, the metrics in the title.
std::string trajectorySvg(const RunReport& r);
/// Position error over distance travelled (SVG); empty string without ground truth.
std::string errorOverDistanceSvg(const RunReport& r);
/// The whole page (self-contained except for `pictures`, referenced by file name).
std::string reportHtml(const RunReport& r);

}  // namespace obm::slam
