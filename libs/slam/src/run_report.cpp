#include "run_report.hpp"

#include <algorithm>
#include <cmath>
#include <iomanip>
#include <sstream>

namespace obm::slam {

namespace {

std::string esc(const std::string& s) {
  std::string o;
  for (char c : s) {
    if (c == '<') o += "&lt;";
    else if (c == '>') o += "&gt;";
    else if (c == '&') o += "&amp;";
    else if (c == '"') o += "&quot;";
    else o += c;
  }
  return o;
}

std::string num(double v, int digits) {
  std::ostringstream os;
  os << std::fixed << std::setprecision(digits) << v;
  return os.str();
}

/// A "nice" tick step (1, 2 or 5 × 10^k) giving about `n` ticks over `span`.
double niceStep(double span, int n) {
  const double raw = std::max(span, 1e-9) / n;
  const double p = std::pow(10.0, std::floor(std::log10(raw)));
  for (double m : {1.0, 2.0, 5.0, 10.0})
    if (m * p >= raw) return m * p;
  return 10 * p;
}

std::string metricValue(const nlohmann::json& j, const char* key, int digits, const char* unit) {
  if (!j.contains(key) || !j[key].is_number()) return "–";
  return num(j[key].get<double>(), digits) + unit;
}

/// Plot frame: data box [x0, x1] × [y0, y1] into a W × H pixel area with margins.
struct Frame {
  double x0, x1, y0, y1, W, H, left = 70, right = 20, top = 50, bottom = 50;
  double sx() const { return (W - left - right) / (x1 - x0); }
  double sy() const { return (H - top - bottom) / (y1 - y0); }
  double px(double x) const { return left + (x - x0) * sx(); }
  double py(double y) const { return H - bottom - (y - y0) * sy(); }
};

std::string axes(const Frame& f, const std::string& xlabel, const std::string& ylabel) {
  std::ostringstream o;
  o << "<rect x='" << f.left << "' y='" << f.top << "' width='" << f.W - f.left - f.right
    << "' height='" << f.H - f.top - f.bottom << "' fill='none' stroke='#444'/>\n";
  const double xs = niceStep(f.x1 - f.x0, 8), ys = niceStep(f.y1 - f.y0, 8);
  // Decimals the step needs (0.05 → 2); ticks at exact multiples print without "-0".
  auto decimals = [](double step) {
    return step >= 1 ? 0 : static_cast<int>(std::ceil(-std::log10(step) - 1e-9));
  };
  auto clean = [](double v, double step) { return std::abs(v) < 1e-6 * step ? 0.0 : v; };
  const int xd = decimals(xs), yd = decimals(ys);
  for (double x = std::ceil(f.x0 / xs) * xs; x <= f.x1 + 1e-9; x += xs) {
    o << "<line x1='" << f.px(x) << "' y1='" << f.top << "' x2='" << f.px(x) << "' y2='"
      << f.H - f.bottom << "' stroke='#eee'/>";
    o << "<text x='" << f.px(x) << "' y='" << f.H - f.bottom + 16
      << "' font-size='11' text-anchor='middle'>" << num(clean(x, xs), xd) << "</text>\n";
  }
  for (double y = std::ceil(f.y0 / ys) * ys; y <= f.y1 + 1e-9; y += ys) {
    o << "<line x1='" << f.left << "' y1='" << f.py(y) << "' x2='" << f.W - f.right << "' y2='"
      << f.py(y) << "' stroke='#eee'/>";
    o << "<text x='" << f.left - 6 << "' y='" << f.py(y) + 4
      << "' font-size='11' text-anchor='end'>" << num(clean(y, ys), yd) << "</text>\n";
  }
  o << "<text x='" << (f.left + f.W - f.right) / 2 << "' y='" << f.H - 12
    << "' font-size='12' text-anchor='middle'>" << esc(xlabel) << "</text>\n";
  o << "<text x='16' y='" << (f.top + f.H - f.bottom) / 2
    << "' font-size='12' text-anchor='middle' transform='rotate(-90 16 "
    << (f.top + f.H - f.bottom) / 2 << ")'>" << esc(ylabel) << "</text>\n";
  return o.str();
}

std::string polyline(const Frame& f, const std::vector<Eigen::Vector2d>& pts, const char* color,
                     double width, const char* cls) {
  std::ostringstream o;
  o << "<polyline class='" << cls << "' fill='none' stroke='" << color << "' stroke-width='"
    << width << "' points='";
  for (const auto& p : pts) o << num(f.px(p.x()), 1) << ',' << num(f.py(p.y()), 1) << ' ';
  o << "'/>\n";
  return o.str();
}

}  // namespace

std::string trajectorySvg(const RunReport& r) {
  Eigen::Vector2d lo(1e300, 1e300), hi(-1e300, -1e300);
  for (const auto* v : {&r.estimate, &r.reference})
    for (const auto& p : *v) {
      lo = lo.cwiseMin(p);
      hi = hi.cwiseMax(p);
    }
  if (r.estimate.empty()) lo = hi = Eigen::Vector2d::Zero();
  const double span = std::max({hi.x() - lo.x(), hi.y() - lo.y(), 1.0});
  const Eigen::Vector2d mid = 0.5 * (lo + hi);
  // Equal scale on both axes: a square data box around the path, 5 % margin.
  Frame f{mid.x() - 0.55 * span, mid.x() + 0.55 * span, mid.y() - 0.55 * span,
          mid.y() + 0.55 * span, 760, 780};
  std::ostringstream o;
  o << "<svg xmlns='http://www.w3.org/2000/svg' width='" << f.W << "' height='" << f.H
    << "' viewBox='0 0 " << f.W << ' ' << f.H << "' font-family='sans-serif'>\n";
  o << "<rect width='100%' height='100%' fill='white'/>\n";
  const auto& m = r.metrics;
  o << "<text x='" << f.W / 2 << "' y='20' font-size='14' text-anchor='middle' font-weight='bold'>"
    << esc(r.title) << "</text>\n";
  o << "<text class='metrics' x='" << f.W / 2 << "' y='38' font-size='12' text-anchor='middle'>"
    << "ATE " << metricValue(m, "ate_rmse_m", 3, " m") << " · t_err "
    << metricValue(m, "t_err_percent", 2, " %") << " · r_err "
    << metricValue(m, "r_err_deg_per_100m", 3, " °/100 m") << " · loops "
    << (m.contains("loops_accepted") ? m["loops_accepted"].dump() : "–") << " · "
    << metricValue(r.timing, "frames_per_second", 1, " frames/s") << "</text>\n";
  o << axes(f, "x [m]", "y [m]");
  // The reference wider and below: visible around an estimate that lies on it.
  if (!r.reference.empty()) o << polyline(f, r.reference, "black", 3.5, "reference");
  o << polyline(f, r.estimate, "#d62728", 1.5, "estimate");
  for (const auto& [a, b] : r.loops)
    if (a < r.estimate.size() && b < r.estimate.size())
      o << "<line class='loop' x1='" << f.px(r.estimate[a].x()) << "' y1='"
        << f.py(r.estimate[a].y()) << "' x2='" << f.px(r.estimate[b].x()) << "' y2='"
        << f.py(r.estimate[b].y()) << "' stroke='#1f77b4' stroke-width='1.5'/>\n";
  if (!r.estimate.empty())
    o << "<circle cx='" << f.px(r.estimate.front().x()) << "' cy='" << f.py(r.estimate.front().y())
      << "' r='5' fill='#2ca02c'/>\n";
  // Scale bar: a nice length near a fifth of the box, bottom right.
  const double bar = niceStep(span, 5);
  const double bx = f.W - f.right - 20 - bar * f.sx(), by = f.H - f.bottom - 18;
  o << "<g class='scalebar'><line x1='" << bx << "' y1='" << by << "' x2='" << bx + bar * f.sx()
    << "' y2='" << by << "' stroke='black' stroke-width='3'/><text x='" << bx + bar * f.sx() / 2
    << "' y='" << by - 6 << "' font-size='12' text-anchor='middle'>" << num(bar, bar < 1 ? 1 : 0)
    << " m</text></g>\n";
  // Legend, top left.
  const double lx = f.left + 12, ly = f.top + 16;
  o << "<g class='legend' font-size='12'><rect x='" << lx - 6 << "' y='" << ly - 12
    << "' width='180' height='" << (r.reference.empty() ? 62 : 80)
    << "' fill='white' stroke='#aaa'/>";
  double yy = ly;
  auto entry = [&](const char* color, const char* label, bool dot) {
    if (dot)
      o << "<circle cx='" << lx + 10 << "' cy='" << yy - 4 << "' r='5' fill='" << color << "'/>";
    else
      o << "<line x1='" << lx << "' y1='" << yy - 4 << "' x2='" << lx + 20 << "' y2='" << yy - 4
        << "' stroke='" << color << "' stroke-width='2'/>";
    o << "<text x='" << lx + 28 << "' y='" << yy << "'>" << label << "</text>";
    yy += 18;
  };
  entry("#d62728", "estimate", false);
  if (!r.reference.empty()) entry("black", "ground truth (aligned)", false);
  entry("#1f77b4", "loop closure", false);
  entry("#2ca02c", "start", true);
  o << "</g>\n</svg>\n";
  return o.str();
}

std::string errorOverDistanceSvg(const RunReport& r) {
  if (r.error_m.empty() || r.error_m.size() != r.distance_m.size()) return {};
  const double dmax = std::max(r.distance_m.back(), 1.0);
  const double emax = std::max(*std::max_element(r.error_m.begin(), r.error_m.end()) * 1.1, 1e-3);
  Frame f{0, dmax, 0, emax, 760, 300};
  f.top = 30;
  std::ostringstream o;
  o << "<svg xmlns='http://www.w3.org/2000/svg' width='" << f.W << "' height='" << f.H
    << "' font-family='sans-serif'>\n<rect width='100%' height='100%' fill='white'/>\n";
  o << "<text x='" << f.W / 2
    << "' y='18' font-size='13' text-anchor='middle'>position error (ATE, after alignment) over "
       "distance travelled</text>\n";
  o << axes(f, "distance along the ground truth [m]", "error [m]");
  std::vector<Eigen::Vector2d> pts;
  for (std::size_t i = 0; i < r.error_m.size(); ++i) pts.emplace_back(r.distance_m[i], r.error_m[i]);
  o << polyline(f, pts, "#d62728", 1.2, "error");
  o << "</svg>\n";
  return o.str();
}

std::string reportHtml(const RunReport& r) {
  std::ostringstream o;
  o << "<!DOCTYPE html>\n<html lang='en'><head><meta charset='utf-8'><title>obm-map: "
    << esc(r.title) << "</title>\n<style>body{font-family:sans-serif;margin:24px;max-width:1600px}"
       "table{border-collapse:collapse;margin:8px 0 20px}td,th{border:1px solid #ccc;padding:3px "
       "8px;text-align:right}th{background:#f4f4f4}td:first-child,th:first-child{text-align:left}"
       ".row{display:flex;flex-wrap:wrap;gap:24px;align-items:flex-start}img{max-width:760px;"
       "border:1px solid #ccc}</style></head><body>\n";
  o << "<h1>obm-map: " << esc(r.title) << "</h1>\n";
  o << "<div class='row'><div id='trajectory'>" << trajectorySvg(r) << "</div><div>";
  const std::string err = errorOverDistanceSvg(r);
  if (!err.empty()) o << "<div id='error'>" << err << "</div>";
  o << "<h2>Metrics</h2><table id='metrics'><tr><th>metric</th><th>value</th></tr>";
  for (const auto& [k, v] : r.metrics.items())
    o << "<tr><td>" << esc(k) << "</td><td>"
      << esc(v.is_number_float() ? num(v.get<double>(), 5) : (v.is_string() ? v.get<std::string>() : v.dump()))
      << "</td></tr>";
  o << "</table><h2>Frames</h2><table id='frames'><tr><th>status</th><th>frames</th></tr>";
  for (const auto& [s, c] : r.status_counts)
    o << "<tr><td>" << esc(s) << "</td><td>" << c << "</td></tr>";
  o << "</table></div></div>\n";
  for (const auto& p : r.pictures)
    o << "<h2>" << esc(p) << "</h2><img src='" << esc(p) << "' alt='" << esc(p) << "'>\n";
  if (r.timing.contains("stages_ms")) {
    o << "<h2>Time</h2><table id='timing'><tr><th>stage</th><th>total [ms]</th><th>per frame "
         "[ms]</th></tr>";
    for (const auto& [k, v] : r.timing["stages_ms"].items()) {
      const double per = r.timing.contains("per_frame_ms") && r.timing["per_frame_ms"].contains(k)
                             ? r.timing["per_frame_ms"][k].get<double>()
                             : 0.0;
      o << "<tr><td>" << esc(k) << "</td><td>" << num(v.get<double>(), 0) << "</td><td>"
        << num(per, 2) << "</td></tr>";
    }
    o << "</table>";
  }
  o << "</body></html>\n";
  return o.str();
}

}  // namespace obm::slam
