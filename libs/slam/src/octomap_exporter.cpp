#include "obm/slam/octomap_exporter.hpp"

#include "top_view_png.hpp"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <iomanip>
#include <optional>
#include <sstream>

#include "obm/core/errors.hpp"
#include "obm/core/log.hpp"
#include "obm/core/progress.hpp"
#include "obm/core/timer.hpp"
#include "obm/io/dataset_kind.hpp"
#include "obm/io/frame_stream.hpp"
#include "obm/io/kitti.hpp"
#include "obm/io/trajectory.hpp"

namespace obm::slam {

namespace fs = std::filesystem;
using mapping::InsertResult;
using mapping::MapKind;
using InputKind = io::DatasetKind;

namespace {

constexpr const char* kLog = "obm-octomap";

std::string lower(std::string s) {
  std::transform(s.begin(), s.end(), s.begin(),
                 [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  return s;
}

std::string formatName(TrajectoryFormat f) {
  switch (f) {
    case TrajectoryFormat::Kitti:
      return "kitti";
    case TrajectoryFormat::Tum:
      return "tum";
    case TrajectoryFormat::Auto:
      break;
  }
  return "auto";
}

/// The parent folder of an output must exist before any work starts, so a typo fails at once.
void checkOutputFolder(const std::string& path, const char* what) {
  const fs::path parent = fs::path(path).parent_path();
  if (!parent.empty() && !fs::is_directory(parent))
    throw IoError(std::string(what) + " '" + path + "': folder '" + parent.string() +
                  "' does not exist");
}

/// An obm-map output folder holds trajectory_kitti.txt and / or trajectory_tum.txt; a KITTI input
/// prefers the KITTI file (camera-frame poses, one per scan), other inputs the TUM one.
std::string resolveTrajectory(const std::string& traj, InputKind kind) {
  if (traj.empty())
    throw ConfigError(
        "--trajectory: a trajectory file (or obm-map output folder) "
        "is required");
  if (!fs::exists(traj)) throw IoError("trajectory '" + traj + "' does not exist");
  if (!fs::is_directory(traj)) return traj;
  const fs::path kitti = fs::path(traj) / "trajectory_kitti.txt";
  const fs::path tum = fs::path(traj) / "trajectory_tum.txt";
  const bool prefer_kitti = kind == InputKind::Kitti;
  for (const fs::path& c :
       prefer_kitti ? std::vector<fs::path>{kitti, tum} : std::vector<fs::path>{tum, kitti})
    if (fs::is_regular_file(c)) return c.string();
  throw IoError("trajectory folder '" + traj +
                "' holds neither trajectory_kitti.txt nor trajectory_tum.txt");
}

}  // namespace

TrajectoryFormat parseTrajectoryFormat(const std::string& s) {
  const std::string l = lower(s);
  if (l == "auto" || l.empty()) return TrajectoryFormat::Auto;
  if (l == "kitti") return TrajectoryFormat::Kitti;
  if (l == "tum") return TrajectoryFormat::Tum;
  throw ConfigError("--format: '" + s + "' is not one of auto, kitti, tum");
}

TrajectoryFormat detectTrajectoryFormat(const std::string& path) {
  std::ifstream in(path);
  if (!in) throw IoError("cannot read trajectory '" + path + "'");
  std::string line;
  std::size_t line_no = 0;
  while (std::getline(in, line)) {
    ++line_no;
    std::size_t first = line.find_first_not_of(" \t\r");
    if (first == std::string::npos || line[first] == '#') continue;
    // TUM files may separate with commas; count whitespace/comma separated fields.
    for (char& c : line)
      if (c == ',') c = ' ';
    std::istringstream is(line);
    std::string tok;
    std::size_t n = 0;
    while (is >> tok) ++n;
    if (n == 12) return TrajectoryFormat::Kitti;
    if (n == 8) return TrajectoryFormat::Tum;
    throw FormatError(path, line_no,
                      std::to_string(n) +
                          " columns: expected 12 (KITTI, row-major 3x4 pose) or "
                          "8 (TUM, t tx ty tz qx qy qz qw)");
  }
  throw FormatError(path, 0, "no pose line (empty trajectory)");
}

OctomapExporter::OctomapExporter(ExporterOptions options) : opt_(std::move(options)) {
  if (opt_.input.empty()) throw ConfigError("--input: a sequence folder or rawlog is required");
  if (opt_.output.empty()) throw ConfigError("--out: a map file (*.bt or *.ot) is required");
  const std::string ext = lower(fs::path(opt_.output).extension().string());
  if (ext != ".bt" && ext != ".ot")
    throw ConfigError("--out '" + opt_.output +
                      "': the extension must be .bt (binary, maximum likelihood) or .ot (full "
                      "probabilities and colours)");
  if (!opt_.png.empty() && lower(fs::path(opt_.png).extension().string()) != ".png")
    throw ConfigError("--png '" + opt_.png + "': the picture must end in .png");
  if (opt_.every < 1) throw ConfigError("--every: must be >= 1");
  if (!std::isfinite(opt_.time_offset)) throw ConfigError("--time-offset: must be finite");
  if (!(opt_.max_time_difference > 0.0)) throw ConfigError("--max-dt: must be > 0 [s]");
  opt_.mapping.validate();
}

ExportSummary OctomapExporter::run() {
  Timer total;
  ExportSummary sum;
  sum.output = opt_.output;

  // ---- 1. Check everything before any work: outputs' folders, input layout, trajectory.
  checkOutputFolder(opt_.output, "--out");
  if (!opt_.png.empty()) checkOutputFolder(opt_.png, "--png");
  const InputKind kind = io::detectDatasetKind(opt_.input);
  sum.input_kind = io::toString(kind);
  sum.trajectory_path = resolveTrajectory(opt_.trajectory, kind);
  const TrajectoryFormat detected = detectTrajectoryFormat(sum.trajectory_path);
  if (opt_.format != TrajectoryFormat::Auto && opt_.format != detected)
    throw FormatError(sum.trajectory_path, 0,
                      "--format " + formatName(opt_.format) + " but the file looks like " +
                          formatName(detected) + " (" +
                          (detected == TrajectoryFormat::Kitti ? "12" : "8") + " columns)");
  sum.trajectory_format = detected;

  // A KITTI folder checks a KITTI trajectory against its scans itself (count, line format).
  const bool kitti_traj = detected == TrajectoryFormat::Kitti;
  io::FrameStreamOptions so;
  so.ground_truth = kind == InputKind::Kitti && kitti_traj ? sum.trajectory_path : "";
  so.depth_max = opt_.rgbd_max_depth;
  so.rgbd_color = opt_.color;
  so.log_component = kLog;
  std::unique_ptr<io::FrameStream> source = io::FrameStream::open(opt_.input, so);
  const std::vector<double> stamps = source->timestamps();
  sum.frames = stamps.size();

  // ---- 2. A pose (of the cloud's frame) per frame, or none.
  std::vector<std::optional<Isometry3d>> pose(sum.frames);
  if (kitti_traj) {
    std::vector<Isometry3d> poses = io::readKittiTrajectory(sum.trajectory_path);
    if (poses.size() != sum.frames)
      throw FormatError(sum.trajectory_path, 0,
                        std::to_string(poses.size()) + " poses but " + std::to_string(sum.frames) +
                            " frames in '" + opt_.input +
                            "' (a KITTI-format trajectory needs one pose per frame)");
    // KITTI-format poses are camera-0 poses, as in the dataset's poses.txt.
    if (const io::KittiCalib* calib = source->kittiCalib())
      poses = io::cameraToLidarPoses(poses, calib->T_cam0_velo);
    for (std::size_t i = 0; i < poses.size(); ++i) pose[i] = poses[i];
  } else {
    const io::Trajectory traj = io::readTumTrajectory(sum.trajectory_path);
    const auto matches = io::associateTimestamps(stamps, io::timestampsOf(traj),
                                                 opt_.max_time_difference, opt_.time_offset);
    for (const auto& m : matches) pose[m.first] = traj[m.second].T;
    if (matches.empty()) {
      // Name both time ranges: a constant offset (sequence time vs. UNIX time) is the usual cause.
      const auto range = [](const std::vector<double>& t) {
        std::ostringstream os;
        os << std::setprecision(15);
        if (t.empty()) return std::string("none");
        os << *std::min_element(t.begin(), t.end()) << " .. "
           << *std::max_element(t.begin(), t.end()) << " s";
        return os.str();
      };
      std::ostringstream msg;
      msg << "no pose time stamp is within " << opt_.max_time_difference << " s of a frame of '"
          << opt_.input << "' (" << traj.size() << " poses at " << range(io::timestampsOf(traj))
          << "; " << sum.frames << " frames at " << range(stamps)
          << "; see --max-dt, --time-offset)";
      throw FormatError(sum.trajectory_path, 0, msg.str());
    }
  }
  std::vector<std::size_t> selected;
  for (std::size_t i = 0; i < sum.frames; ++i) {
    if (!pose[i]) continue;
    ++sum.frames_with_pose;
    if (i % opt_.every == 0) selected.push_back(i);
  }
  sum.frames_selected = selected.size();
  if (sum.frames_with_pose < sum.frames)
    OBM_LOG_WARN(kLog, (sum.frames - sum.frames_with_pose)
                           << " of " << sum.frames << " frames have no pose within "
                           << opt_.max_time_difference << " s and are skipped");

  // ---- 3. Integration. The tree type follows the first cloud (colour or not).
  std::optional<OccupancyMap> map;
  Timer integrate;
  ProgressBar bar(selected.size(), "octomap", "scans");
  std::size_t next_frame = 0;
  bar.setEnabled(opt_.progress);
  for (std::size_t k = 0; k < selected.size(); ++k) {
    if (opt_.cancel && opt_.cancel->load()) {
      sum.interrupted = true;
      break;
    }
    // The stream moves forward only: past the frames that are not integrated, to frame i.
    const std::size_t i = selected[k];
    for (; next_frame < i; ++next_frame)
      if (!source->skip())
        throw FormatError(opt_.input, 0, "frame " + std::to_string(next_frame) + " vanished while reading");
    PointCloud cloud;
    if (!source->next(cloud))
      throw FormatError(opt_.input, 0, "frame " + std::to_string(i) + " vanished while reading");
    ++next_frame;
    if (cloud.empty()) continue;  // unreadable (named in a warning, counted)
    if (!map) {
      const bool color = opt_.color && cloud.hasColors();
      map.emplace(opt_.mapping, color ? MapKind::Color : MapKind::Occupancy);
    }
    const InsertResult r = map->insert(cloud, *pose[i]);
    sum.points += r.points_in;
    sum.rays += r.rays;
    sum.beams += r.beams;
    ++sum.frames_integrated;
    if (opt_.progress) {
      std::ostringstream status;
      status << "frame " << i << ", " << r.beams << " beams, " << std::fixed << std::setprecision(0)
             << r.time_ms << " ms";
      bar.update(k + 1, status.str());
    }
  }
  bar.finish();
  sum.read_errors = source->readErrors();
  if (sum.read_errors > 0)
    OBM_LOG_WARN(kLog, sum.read_errors << " frame(s) could not be read and were skipped");
  if (!map) map.emplace(opt_.mapping, MapKind::Occupancy);
  sum.integrate_s = integrate.seconds();
  sum.color = map->kind() == MapKind::Color;
  if (opt_.color && !sum.color && sum.frames_integrated > 0)
    OBM_LOG_WARN(kLog, "--color: the clouds of '"
                           << opt_.input
                           << "' carry no colour (no colour images registered to depth, or "
                              "a rawlog without coloured clouds); wrote an occupancy-only OcTree");

  // ---- 4. Outputs, atomically.
  map->write(opt_.output);
  sum.stats = map->stats();
  if (!opt_.png.empty()) {
    if (sum.stats.empty()) {
      OBM_LOG_WARN(kLog, "the map is empty; no picture written to '" << opt_.png << "'");
    } else {
      TopViewOptions tv = opt_.top_view;
      tv.use_voxel_color = tv.use_voxel_color && sum.color;
      sum.top_view = writeTopViewPng(*map, opt_.png, tv);
      sum.png = opt_.png;
    }
  }
  sum.total_s = total.seconds();
  return sum;
}

std::string formatSummary(const ExportSummary& s) {
  std::ostringstream os;
  os << "input           " << s.input_kind << ", " << s.frames << " frames (" << s.frames_with_pose
     << " with a pose, " << s.frames_selected << " selected)\n";
  os << "trajectory      " << s.trajectory_path << " (" << formatName(s.trajectory_format) << ")\n";
  os << "integrated      " << s.frames_integrated << " frames, " << s.points << " points, "
     << s.beams << " beams cast" << (s.interrupted ? " (interrupted)" : "") << "\n";
  os << "map             " << s.output << (s.color ? " (ColorOcTree)" : " (OcTree)") << "\n";
  os << formatStats(s.stats);
  if (!s.png.empty())
    os << "top view        " << s.png << " (" << s.top_view.width << " x " << s.top_view.height
       << " px, " << std::fixed << std::setprecision(3) << s.top_view.pixel_size << " m/px, height "
       << std::setprecision(2) << s.top_view.z_low << " .. " << s.top_view.z_high << " m)\n";
  os << std::fixed << std::setprecision(2) << "time            " << s.total_s << " s ("
     << s.integrate_s << " s integration";
  if (s.frames_integrated > 0)
    os << ", " << std::setprecision(1) << 1e3 * s.integrate_s / s.frames_integrated << " ms/frame";
  os << ")\n";
  return os.str();
}

}  // namespace obm::slam
