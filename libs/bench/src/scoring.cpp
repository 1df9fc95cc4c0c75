#include "obm/bench/scoring.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iomanip>
#include <map>
#include <nlohmann/json.hpp>
#include <regex>
#include <sstream>

#include "obm/core/atomic_file.hpp"
#include "obm/core/csv.hpp"
#include "obm/core/errors.hpp"
#include "obm/core/log.hpp"
#include "obm/core/progress.hpp"
#include "obm/core/timer.hpp"
#include "obm/eval/statistics.hpp"
#include "obm/io/point_cloud_io.hpp"

namespace fs = std::filesystem;

namespace obm::bench {

std::vector<obmnet::RegistrationPair> readPairFolder(const std::string& dir) {
  if (!fs::is_directory(dir)) throw IoError(dir + ": pair folder not found");
  const std::string gt_path = dir + "/gt.txt";
  std::ifstream in(gt_path);
  if (!in) throw IoError(gt_path + ": cannot open (every pair folder needs a gt.txt)");
  std::vector<obmnet::RegistrationPair> pairs;
  std::string line;
  std::size_t line_no = 0;
  while (std::getline(in, line)) {
    ++line_no;
    if (line.empty() || line[0] == '#') continue;
    std::istringstream is(line);
    std::string id;
    std::array<double, 12> v{};
    if (!(is >> id)) continue;
    for (auto& x : v)
      if (!(is >> x))
        throw FormatError(gt_path, line_no,
                          "expected an id and 12 numbers (row-major 3×4 T_tgt_src)");
    std::string extra;
    if (is >> extra) throw FormatError(gt_path, line_no, "more than 13 columns");
    obmnet::RegistrationPair p;
    p.name = id;
    p.T_target_source = fromRowMajor3x4(v);
    if (!p.T_target_source.matrix().allFinite())
      throw FormatError(gt_path, line_no, "non-finite pose");
    // The id may be written with or without zero padding: try the file names as they exist.
    std::string src, tgt;
    for (const std::string& prefix : {std::string("pair_"), std::string()}) {
      const std::string s = dir + "/" + prefix + id + "_src.ply",
                        t = dir + "/" + prefix + id + "_tgt.ply";
      if (fs::exists(s) && fs::exists(t)) {
        src = s;
        tgt = t;
        break;
      }
    }
    if (src.empty())
      throw IoError(gt_path + ":" + std::to_string(line_no) + ": no pair_" + id +
                    "_src.ply / pair_" + id + "_tgt.ply (or " + id + "_src.ply / " + id +
                    "_tgt.ply) in " + dir);
    p.source = io::readPointCloud(src);
    p.target = io::readPointCloud(tgt);
    if (p.source.empty() || p.target.empty())
      throw FormatError(src, 0, "empty cloud in pair " + id);
    pairs.push_back(std::move(p));
  }
  if (pairs.empty()) throw FormatError(gt_path, 0, "no pairs listed");
  return pairs;
}

void writePairFolder(const std::string& dir, const std::vector<obmnet::RegistrationPair>& pairs) {
  ensureDirectory(dir);
  std::ostringstream gt;
  gt << std::setprecision(17);
  for (std::size_t i = 0; i < pairs.size(); ++i) {
    char id[24];  // "%04zu" of any size_t fits
    std::snprintf(id, sizeof(id), "%04zu", i);
    io::writePointCloud(dir + "/pair_" + id + "_src.ply", pairs[i].source, true);
    io::writePointCloud(dir + "/pair_" + id + "_tgt.ply", pairs[i].target, true);
    gt << id;
    for (double x : toRowMajor3x4(pairs[i].T_target_source)) gt << ' ' << x;
    gt << '\n';
  }
  writeTextAtomically(dir + "/gt.txt", gt.str());
}

std::vector<MethodScores> runBenchmark(const std::vector<obmnet::RegistrationPair>& pairs,
                                       const std::vector<Method>& methods,
                                       const eval::RecallThresholds& recall, bool progress,
                                       const PoseScorer& extra) {
  std::vector<MethodScores> out;
  for (const auto& m : methods) {
    eval::RegistrationAccumulator acc(recall);
    MethodScores s;
    s.name = m.name;
    ProgressBar bar(pairs.size(), m.name, "pairs");
    bar.setEnabled(progress);
    for (const auto& p : pairs) {
      Timer t;
      Isometry3d T = Isometry3d::Identity();
      bool failed = false;
      std::vector<std::pair<std::string, double>> conf;
      try {
        MethodResult r = m.start_at_truth
                             ? m.fn(p.source.transformed(p.T_target_source, p.target.frame_id),
                                    p.target)
                             : m.fn(p.source, p.target);
        T = m.start_at_truth ? Isometry3d(r.T_target_source * p.T_target_source)
                             : r.T_target_source;
        conf = std::move(r.scores);
      } catch (const std::exception& e) {
        // Scored as a failure at the identity; the reason is logged so that it can be told from
        // a wrong pose.
        ++s.failures;
        failed = true;
        OBM_LOG_WARN("obm-bench", m.name << " failed on pair " << p.name << ": " << e.what());
      }
      const double ms = t.ms();
      if (extra && !failed && !m.start_at_truth)
        for (auto& score : extra(p.source, p.target, T)) conf.push_back(std::move(score));
      s.per_pair.push_back(acc.add(T, p.T_target_source, ms));
      s.per_pair_ms.push_back(ms);
      s.per_pair_failed.push_back(failed);
      s.per_pair_scores.push_back(std::move(conf));
      s.per_pair_T.push_back(T);
      bar.tick();
    }
    s.summary = acc.summary();
    std::ostringstream st;
    st << std::setprecision(4) << "MIE(R) " << s.summary.mie_r << " deg, recall "
       << s.summary.recall;
    bar.finish(st.str());
    out.push_back(s);
  }
  return out;
}

void scoreSurfaces(const std::vector<obmnet::RegistrationPair>& pairs,
                   const std::vector<const eval::SurfaceErrorScorer*>& scorer_of_pair,
                   std::vector<MethodScores>& scores) {
  OBM_ASSERT(scorer_of_pair.size() == pairs.size(), "scoreSurfaces: one scorer per pair");
  for (auto& s : scores) {
    s.per_pair_surface.resize(pairs.size());
    for (std::size_t i = 0; i < pairs.size(); ++i)
      s.per_pair_surface[i] =
          scorer_of_pair[i]->error(s.per_pair_T.at(i), pairs[i].T_target_source);
  }
}

namespace {

double recallUpToSymmetry(const MethodScores& s, double max_surface_error) {
  std::size_t ok = 0;
  for (std::size_t i = 0; i < s.per_pair_surface.size(); ++i)
    ok += !s.per_pair_failed[i] && s.per_pair_surface[i] < max_surface_error ? 1 : 0;
  return s.per_pair_surface.empty()
             ? 0.0
             : static_cast<double>(ok) / static_cast<double>(s.per_pair_surface.size());
}

}  // namespace

std::string surfaceTable(const std::vector<MethodScores>& scores,
                         const eval::RecallThresholds& recall, double max_surface_error) {
  std::ostringstream os;
  char buf[320];
  std::snprintf(buf, sizeof(buf),
                "| method | recall (RRE < %g°, RTE < %g) | recall up to symmetry (surface error "
                "< %g) | median surface error |\n|---|---:|---:|---:|\n",
                recall.max_rre_deg, recall.max_rte, max_surface_error);
  os << buf;
  for (const auto& s : scores) {
    if (s.per_pair_surface.empty()) continue;
    std::snprintf(buf, sizeof(buf), "| %s | %.1f %% | %.1f %% | %.5f |\n", s.name.c_str(),
                  100.0 * s.summary.recall, 100.0 * recallUpToSymmetry(s, max_surface_error),
                  eval::median(s.per_pair_surface));
    os << buf;
  }
  return os.str();
}

std::vector<ConfidenceRating> rateConfidences(const std::vector<MethodScores>& scores,
                                              const eval::RecallThresholds& recall) {
  std::vector<ConfidenceRating> out;
  for (const auto& s : scores) {
    std::vector<std::string> names;
    for (const auto& pp : s.per_pair_scores)
      for (const auto& [name, v] : pp)
        if (std::find(names.begin(), names.end(), name) == names.end()) names.push_back(name);
    for (const auto& name : names) {
      std::vector<double> v;
      std::vector<bool> ok;
      for (std::size_t i = 0; i < s.per_pair.size(); ++i) {
        // A pair where the method threw or gave no such score counts as the lowest score.
        double x = -1e300;
        for (const auto& [n, val] : s.per_pair_scores[i])
          if (n == name && std::isfinite(val)) x = val;
        v.push_back(x);
        ok.push_back(!s.per_pair_failed[i] &&
                     recall.accepts(s.per_pair[i].rre_deg, s.per_pair[i].rte));
      }
      ConfidenceRating r;
      r.method = s.name;
      r.score = name;
      r.auroc = eval::auroc(v, ok);
      r.correct = static_cast<std::size_t>(std::count(ok.begin(), ok.end(), true));
      r.wrong = ok.size() - r.correct;
      out.push_back(r);
    }
  }
  return out;
}

std::string confidenceTable(const std::vector<ConfidenceRating>& ratings) {
  std::ostringstream os;
  os << "| method | confidence score | AUROC (correct vs wrong) | correct | wrong |\n"
     << "|---|---|---:|---:|---:|\n";
  char buf[256];
  for (const auto& r : ratings) {
    if (std::isnan(r.auroc))
      std::snprintf(buf, sizeof(buf), "| %s | %s | – | %zu | %zu |\n", r.method.c_str(),
                    r.score.c_str(), r.correct, r.wrong);
    else
      std::snprintf(buf, sizeof(buf), "| %s | %s | %.3f | %zu | %zu |\n", r.method.c_str(),
                    r.score.c_str(), r.auroc, r.correct, r.wrong);
    os << buf;
  }
  return os.str();
}

std::string markdownTable(const std::vector<MethodScores>& scores, const std::string& title) {
  std::ostringstream os;
  if (!title.empty()) os << "**" << title << "**\n\n";
  os << "| method | MAE(R) ° | MAE(t) | MIE(R) ° | MIE(t) | recall | median ms |\n"
     << "|---|---:|---:|---:|---:|---:|---:|\n";
  char buf[256];
  for (const auto& s : scores) {
    const auto& r = s.summary;
    std::snprintf(buf, sizeof(buf), "| %s | %.4f | %.5f | %.4f | %.5f | %.1f %% | %.1f |",
                  s.name.c_str(), r.mae_r, r.mae_t, r.mie_r, r.mie_t, 100.0 * r.recall,
                  r.median_ms);
    os << buf;
    if (s.failures) os << " (" << s.failures << " failed)";
    os << "\n";
  }
  return os.str();
}

std::string jsonReport(std::size_t n_pairs, const std::vector<MethodScores>& scores,
                       const eval::RecallThresholds& recall, const std::string& info,
                       const std::vector<ConfidenceRating>& ratings,
                       double max_surface_error) {
  nlohmann::json j;
  j["pairs"] = n_pairs;
  j["recall_thresholds"] = {{"max_rre_deg", recall.max_rre_deg}, {"max_rte", recall.max_rte}};
  j["info"] = info;
  nlohmann::json methods = nlohmann::json::object();
  for (const auto& s : scores) {
    const auto& r = s.summary;
    methods[s.name] = {
        {"mae_r", r.mae_r},     {"mae_t", r.mae_t},      {"mie_r", r.mie_r},
        {"mie_t", r.mie_t},     {"recall", r.recall},    {"median_ms", r.median_ms},
        {"rmse_r", r.rmse_r},   {"rmse_t", r.rmse_t},    {"median_rre_deg", r.median_rre_deg},
        {"mean_ms", r.mean_ms}, {"failures", s.failures}};
    if (max_surface_error > 0.0 && !s.per_pair_surface.empty()) {
      methods[s.name]["recall_up_to_symmetry"] = recallUpToSymmetry(s, max_surface_error);
      methods[s.name]["median_surface_error"] = eval::median(s.per_pair_surface);
    }
  }
  if (max_surface_error > 0.0) j["max_surface_error"] = max_surface_error;
  j["methods"] = methods;
  nlohmann::json conf = nlohmann::json::array();
  for (const auto& r : ratings)
    conf.push_back({{"method", r.method},
                    {"score", r.score},
                    {"auroc", std::isnan(r.auroc) ? nlohmann::json() : nlohmann::json(r.auroc)},
                    {"correct", r.correct},
                    {"wrong", r.wrong}});
  j["confidence_auroc"] = conf;
  return j.dump(2) + "\n";
}

std::string perPairCsv(const std::vector<obmnet::RegistrationPair>& pairs,
                       const std::vector<MethodScores>& scores,
                       const eval::RecallThresholds& recall) {
  std::ostringstream os;
  os << "pair,name,overlap";
  // Score columns: every score name a method gave on any pair.
  std::vector<std::vector<std::string>> score_names(scores.size());
  for (std::size_t m = 0; m < scores.size(); ++m)
    for (const auto& pp : scores[m].per_pair_scores)
      for (const auto& kv : pp)
        if (std::find(score_names[m].begin(), score_names[m].end(), kv.first) ==
            score_names[m].end())
          score_names[m].push_back(kv.first);
  for (std::size_t m = 0; m < scores.size(); ++m) {
    const auto& s = scores[m];
    os << ',' << s.name << "_rre_deg," << s.name << "_rte," << s.name << "_ms," << s.name
       << "_ok";
    if (!s.per_pair_surface.empty()) os << ',' << s.name << "_surface";
    for (const auto& n : score_names[m]) os << ',' << s.name << '_' << n;
  }
  os << '\n';
  char buf[160];
  for (std::size_t i = 0; i < pairs.size(); ++i) {
    // Pair names hold commas ("seq:757->0 (loop, yaw 28°)"): quoted.
    std::snprintf(buf, sizeof(buf), ",%.4f", pairs[i].overlap);
    os << i << ",\"" << csvQuoted(pairs[i].name) << '"' << buf;
    for (std::size_t m = 0; m < scores.size(); ++m) {
      const auto& s = scores[m];
      const auto& e = s.per_pair.at(i);
      const bool ok = !s.per_pair_failed.at(i) && recall.accepts(e.rre_deg, e.rte);
      std::snprintf(buf, sizeof(buf), ",%.6g,%.6g,%.2f,%d", e.rre_deg, e.rte, s.per_pair_ms.at(i),
                    ok ? 1 : 0);
      os << buf;
      if (!s.per_pair_surface.empty()) {
        std::snprintf(buf, sizeof(buf), ",%.6g", s.per_pair_surface.at(i));
        os << buf;
      }
      for (const auto& n : score_names[m]) {
        os << ',';
        for (const auto& kv : s.per_pair_scores.at(i))
          if (kv.first == n) {
            std::snprintf(buf, sizeof(buf), "%.6g", kv.second);
            os << buf;
          }
      }
    }
    os << '\n';
  }
  return os.str();
}

}  // namespace obm::bench
