#include "obm/sim/simulator.hpp"

#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iomanip>
#include <memory>
#include <sstream>

#include "obm/core/atomic_file.hpp"
#include "obm/core/errors.hpp"
#include "obm/core/log.hpp"
#include "obm/core/progress.hpp"
#include "obm/core/timer.hpp"
#include "obm/io/kitti.hpp"
#include "obm/io/rawlog.hpp"
#include "obm/io/rgbd.hpp"
#include "obm/io/trajectory.hpp"
#include "obm/sim/preview.hpp"
#include "obm/sim/random.hpp"
#include "obm/sim/scene.hpp"
#include "source_tree.hpp"
#include "work_queue.hpp"

namespace obm::sim {

namespace fs = std::filesystem;

// ---------------------------------------------------------------------------------------------
// Configuration

std::string expandPath(const std::string& value, const std::string& where) {
  std::string out;
  std::size_t i = 0;
  while (i < value.size()) {
    if (value[i] == '$' && i + 1 < value.size() && value[i + 1] == '{') {
      const std::size_t end = value.find('}', i + 2);
      if (end == std::string::npos)
        throw ConfigError(where + ": unterminated ${...} in '" + value + "'");
      const std::string var = value.substr(i + 2, end - i - 2);
      const char* env = std::getenv(var.c_str());
      std::string rep = env ? env : "";
      if (rep.empty() && var == "OBM_SHARED_DATA") {
        const std::string src = detail::sourceSharedData();
        if (!src.empty() && fs::is_directory(src)) rep = src;
      }
      if (rep.empty())
        throw ConfigError(where + ": '" + value + "' needs the environment variable " + var +
                          (var == "OBM_SHARED_DATA"
                               ? " (the folder holding kitti/ and tum/ ground truth); set it, or "
                                 "pass the file with --trajectory FILE"
                               : "") +
                          ", which is not set");
      out += rep;
      i = end + 1;
    } else {
      out += value[i++];
    }
  }
  return out;
}

namespace {
// The node without some keys (for sections whose parameter struct checks its own keys).
ConfigNode without(const ConfigNode& n, std::initializer_list<const char*> keys) {
  if (!n.valid()) return n;
  YAML::Node copy = YAML::Clone(n.yaml());
  for (const char* k : keys) copy.remove(k);
  const std::string w = n.where();
  const std::string path = w.substr(w.find(": ") == std::string::npos ? 0 : w.find(": ") + 2);
  return ConfigNode(copy, n.file(), path);
}
}  // namespace

SimConfig SimConfig::load(const ConfigNode& root) {
  SimConfig c;
  root.checkKeys({"name", "seed", "frames", "threads", "scene", "sensor", "trajectory", "output"});
  c.source = root.file();
  root.get("name", c.name);
  root.get("seed", c.seed);
  root.get("frames", c.frames);
  root.get("threads", c.threads);
  if (!root.has("scene")) throw ConfigError(root.where("scene") + ": required section is missing");
  if (!root.has("sensor"))
    throw ConfigError(root.where("sensor") + ": required section is missing");
  if (!root.has("trajectory"))
    throw ConfigError(root.where("trajectory") + ": required section is missing");

  // Sensor first: its rate drives the procedural trajectories.
  const ConfigNode sn = root.child("sensor");
  c.sensor.type = sn.required<std::string>("type");
  if (c.sensor.type == "lidar")
    c.sensor.lidar = LidarParams::load(sn);
  else if (c.sensor.type == "rgbd")
    c.sensor.rgbd = RgbdParams::load(sn);
  else
    throw ConfigError(sn.where("type") + ": unknown sensor '" + c.sensor.type +
                      "' (expected lidar or rgbd)");

  const ConfigNode sc = root.child("scene");
  c.scene.type = sc.required<std::string>("type");
  if (c.scene.type == "urban_grid") {
    c.scene.urban = UrbanSceneParams::load(sc);
  } else if (c.scene.type == "urban_around_trajectory") {
    c.scene.urban = UrbanSceneParams::load(without(sc, {"sensor_height"}));
    sc.get("sensor_height", c.scene.sensor_height);
  } else if (c.scene.type == "indoor_floor") {
    c.scene.indoor = IndoorSceneParams::load(sc);
  } else if (c.scene.type == "indoor_room") {
    c.scene.indoor = IndoorSceneParams::load(without(sc, {"floor_z"}));
    sc.get("floor_z", c.scene.floor_z);
  } else if (c.scene.type == "mesh") {
    sc.checkKeys({"type", "file", "scale"});
    c.scene.mesh_file = expandPath(sc.required<std::string>("file"), sc.where("file"));
    sc.get("scale", c.scene.mesh_scale);
  } else {
    throw ConfigError(sc.where("type") + ": unknown scene '" + c.scene.type +
                      "' (expected urban_grid, urban_around_trajectory, indoor_floor, "
                      "indoor_room or mesh)");
  }
  if (c.scene.type == "indoor_floor" || c.scene.type == "indoor_room") {
    const std::string& d = c.scene.indoor.mesh_dir;
    if (!d.empty() && d != "auto") c.scene.indoor.mesh_dir = expandPath(d, sc.where("mesh_dir"));
  }

  const ConfigNode tn = root.child("trajectory");
  c.trajectory.type = tn.required<std::string>("type");
  auto& T = c.trajectory;
  if (T.type == "drive") {
    T.drive = DriveParams::load(without(tn, {"start_time"}));
  } else if (T.type == "walk") {
    T.walk = WalkParams::load(without(tn, {"start_time"}));
  } else if (T.type == "kitti") {
    tn.checkKeys({"type", "file", "times", "calib", "max_poses", "start_time"});
    T.file = expandPath(tn.required<std::string>("file"), tn.where("file"));
    if (tn.has("times"))
      T.times_file = expandPath(tn.required<std::string>("times"), tn.where("times"));
    if (tn.has("calib"))
      T.calib_file = expandPath(tn.required<std::string>("calib"), tn.where("calib"));
    tn.get("max_poses", T.max_poses);
  } else if (T.type == "tum") {
    tn.checkKeys({"type", "file", "max_poses"});
    T.file = expandPath(tn.required<std::string>("file"), tn.where("file"));
    tn.get("max_poses", T.max_poses);
  } else {
    throw ConfigError(tn.where("type") + ": unknown trajectory '" + T.type +
                      "' (expected drive, walk, kitti or tum)");
  }

  if (T.type != "tum") tn.get("start_time", T.start_time);

  const ConfigNode on = root.child("output");
  on.checkKeys({"format", "rawlog", "dataset", "pictures", "rawlog_compression", "depth_scale",
                "sensor_label"});
  on.get("format", c.output.format);
  on.get("rawlog", c.output.rawlog);
  on.get("dataset", c.output.dataset);
  on.get("pictures", c.output.pictures);
  on.get("rawlog_compression", c.output.rawlog_compression);
  on.get("depth_scale", c.output.depth_scale);
  on.get("sensor_label", c.output.sensor_label);
  if (c.output.format == "auto") c.output.format = c.sensor.type == "lidar" ? "kitti" : "tum";
  if (c.output.format != "kitti" && c.output.format != "tum")
    throw ConfigError(on.where("format") + ": unknown format '" + c.output.format +
                      "' (expected kitti, tum or auto)");
  if (c.output.rawlog_compression < 1 || c.output.rawlog_compression > 9)
    throw ConfigError(on.where("rawlog_compression") + ": must be in 1..9");
  if (!(c.output.depth_scale > 0.0))
    throw ConfigError(on.where("depth_scale") + ": must be positive");
  c.applySeed();
  c.validate();
  return c;
}

SimConfig SimConfig::loadFile(const std::string& path) {
  return load(ConfigNode::loadFile(path));
}

void SimConfig::applySeed() {
  scene.urban.seed = hashSeed(seed, 0x5ce4e);
  scene.indoor.seed = hashSeed(seed, 0x5ce4e, 1);
  trajectory.drive.seed = hashSeed(seed, 0x7a1);
  trajectory.walk.seed = hashSeed(seed, 0x7a1, 1);
  trajectory.drive.rate_hz = sensor.lidar.rate_hz;
  trajectory.walk.rate_hz = sensor.rgbd.rate_hz;
  if (threads != 0) sensor.lidar.threads = sensor.rgbd.threads = threads;
}

void SimConfig::validate() const {
  const std::string w = source.empty() ? "<config>" : source;
  const std::string& t = trajectory.type;
  if (t == "drive" && scene.type != "urban_grid")
    throw ConfigError(w + ": trajectory.type: 'drive' needs scene.type 'urban_grid' (got '" +
                      scene.type + "')");
  if (t == "walk" && scene.type != "indoor_floor")
    throw ConfigError(w + ": trajectory.type: 'walk' needs scene.type 'indoor_floor' (got '" +
                      scene.type + "')");
  if ((scene.type == "urban_around_trajectory" || scene.type == "indoor_room") && t != "kitti" &&
      t != "tum")
    throw ConfigError(w + ": scene.type: '" + scene.type +
                      "' is built around a trajectory file: trajectory.type must be kitti or tum");
  if (output.format == "kitti" && sensor.type != "lidar")
    throw ConfigError(w + ": output.format: 'kitti' needs a lidar sensor");
  if (output.format == "tum" && sensor.type != "rgbd")
    throw ConfigError(w + ": output.format: 'tum' needs an rgbd sensor");
  if (sensor.type == "lidar")
    sensor.lidar.validate(w + ": sensor");
  else
    sensor.rgbd.validate(w + ": sensor");
}

namespace {
std::vector<std::string> presetDirs(const std::string& exe_path) {
  std::vector<std::string> dirs;
  if (const char* e = std::getenv("OBM_CONFIG_DIR")) {
    if (*e) {
      dirs.push_back((fs::path(e) / "sim").string());
      dirs.push_back(e);
    }
  }
  if (!exe_path.empty()) {
    std::error_code ec;
    fs::path exe = fs::canonical(exe_path, ec);
    if (ec) exe = fs::absolute(exe_path, ec);
    if (!ec)
      dirs.push_back(
          (exe.parent_path().parent_path() / detail::installDataDir() / "obmslam" / "config" / "sim")
              .lexically_normal()
              .string());
  }
  const std::string src = detail::sourceConfigDir();
  if (!src.empty()) dirs.push_back((fs::path(src) / "sim").string());
  return dirs;
}
}  // namespace

std::vector<std::string> listPresets(const std::string& exe_path) {
  std::vector<std::string> names;
  for (const auto& d : presetDirs(exe_path)) {
    std::error_code ec;
    if (!fs::is_directory(d, ec)) continue;
    for (const auto& e : fs::directory_iterator(d, ec))
      if (e.path().extension() == ".yaml") {
        const std::string n = e.path().stem().string();
        if (std::find(names.begin(), names.end(), n) == names.end()) names.push_back(n);
      }
  }
  std::sort(names.begin(), names.end());
  return names;
}

std::string findPreset(const std::string& name, const std::string& exe_path) {
  if (name.empty() || name.find('/') != std::string::npos || name.find("..") != std::string::npos)
    throw ConfigError("--preset: '" + name +
                      "' is not a preset name (use --config FILE for a path)");
  const auto dirs = presetDirs(exe_path);
  for (const auto& d : dirs) {
    const fs::path p = fs::path(d) / (name + ".yaml");
    std::error_code ec;
    if (fs::is_regular_file(p, ec)) return p.string();
  }
  std::string searched, found;
  for (const auto& d : dirs) searched += "\n  " + d;
  for (const auto& n : listPresets(exe_path)) found += (found.empty() ? "" : ", ") + n;
  throw ConfigError("--preset: unknown preset '" + name + "'; searched:" + searched +
                    "\navailable presets: " + (found.empty() ? "(none found)" : found));
}

namespace {
// "kitti" (12 numbers per line) or "tum" (8 numbers) from the first data line of a pose file.
std::string detectPoseFormat(const std::string& file) {
  std::ifstream is(file);
  if (!is) throw IoError("--trajectory: cannot open pose file '" + file + "'");
  std::string line;
  std::size_t lineno = 0;
  while (std::getline(is, line)) {
    ++lineno;
    const auto first = line.find_first_not_of(" \t\r");
    if (first == std::string::npos || line[first] == '#') continue;
    std::istringstream ls(line);
    std::string tok;
    int n = 0;
    while (ls >> tok) ++n;
    if (n == 12) return "kitti";
    if (n == 8) return "tum";
    throw FormatError(file, lineno,
                      "expected a KITTI pose (12 numbers) or a TUM pose (8 numbers), found " +
                          std::to_string(n) + " fields");
  }
  throw FormatError(file, 0, "no poses in the file");
}
}  // namespace

SimConfig resolveConfig(const SimCommandLine& cl, const std::string& exe_path) {
  if (cl.preset.empty() == cl.config_file.empty())
    throw ConfigError("give exactly one of --preset NAME or --config FILE");
  const std::string file = cl.preset.empty() ? cl.config_file : findPreset(cl.preset, exe_path);
  SimConfig c = SimConfig::loadFile(file);
  if (!cl.preset.empty() && c.name == "sim") c.name = cl.preset;
  if (cl.frames >= 0) c.frames = static_cast<std::size_t>(cl.frames);
  if (cl.seed >= 0) c.seed = static_cast<std::uint64_t>(cl.seed);
  if (cl.threads >= 0) c.threads = cl.threads;
  if (!cl.trajectory.empty()) {
    const std::string fmt = detectPoseFormat(cl.trajectory);
    if (c.trajectory.type == "drive" || c.trajectory.type == "walk" || c.trajectory.type != fmt)
      c.trajectory.type = fmt;
    c.trajectory.file = cl.trajectory;
    c.trajectory.times_file.clear();  // the preset's time stamps belong to its own file
  }
  c.applySeed();
  c.validate();
  return c;
}

// ---------------------------------------------------------------------------------------------
// Simulator

struct SequenceSimulator::State {
  GeneratedScene scene;
  Trajectory traj;
  std::unique_ptr<RaycastScene> rc;
  Eigen::Isometry3d T_cam0_velo = KittiCalibration::kitti00().T_cam0_velo;
  std::vector<double> rel_stamps;  // [s] frame times minus the first, exact
  bool prepared = false;
};

SequenceSimulator::SequenceSimulator(SimConfig config)
    : cfg_(std::move(config)), st_(std::make_unique<State>()) {}
SequenceSimulator::~SequenceSimulator() = default;

const GeneratedScene& SequenceSimulator::scene() const {
  OBM_ASSERT(st_->prepared, "call prepare() first");
  return st_->scene;
}
const Trajectory& SequenceSimulator::trajectory() const {
  OBM_ASSERT(st_->prepared, "call prepare() first");
  return st_->traj;
}

void SequenceSimulator::prepare() {
  if (st_->prepared) return;
  State& s = *st_;
  const auto& tc = cfg_.trajectory;
  Trajectory traj;
  try {
    if (tc.type == "kitti") {
      if (!tc.calib_file.empty()) {
        // KITTI's Tr is orthonormal to ~1e-7 only; projecting it onto SO(3) makes the camera ↔
        // LiDAR conversions exact inverses of each other.
        s.T_cam0_velo = io::readKittiCalib(tc.calib_file).T_cam0_velo;
        s.T_cam0_velo.linear() = orthonormalize(s.T_cam0_velo.linear());
      }
      traj = loadKittiTrajectory(tc.file, tc.times_file, s.T_cam0_velo, tc.max_poses);
    } else if (tc.type == "tum") {
      traj = loadTumTrajectory(tc.file, tc.max_poses).resampled(cfg_.sensor.rate());
    }
  } catch (const IoError& e) {
    // Say where the missing file came from (a preset's ${OBM_SHARED_DATA} path, or --trajectory).
    throw IoError(std::string(e.what()) + " (a trajectory file of " +
                  (cfg_.source.empty() ? std::string("the configuration") : cfg_.source) +
                  "; set OBM_SHARED_DATA to the folder holding kitti/ and tum/, or pass "
                  "--trajectory FILE)");
  }
  const auto& sc = cfg_.scene;
  if (sc.type == "urban_grid")
    s.scene = generateUrbanGrid(sc.urban);
  else if (sc.type == "urban_around_trajectory")
    s.scene = generateUrbanAroundPath(sc.urban, traj, sc.sensor_height);
  else if (sc.type == "indoor_floor")
    s.scene = generateIndoorFloor(sc.indoor);
  else if (sc.type == "indoor_room")
    s.scene = generateRoomAroundTrajectory(sc.indoor, traj, sc.floor_z);
  else
    s.scene = loadMeshScene(sc.mesh_file, sc.mesh_scale);
  if (tc.type == "drive")
    traj = generateDrive(sc.urban, s.scene, tc.drive);
  else if (tc.type == "walk")
    traj = generateWalk(sc.indoor, s.scene, tc.walk);
  // Sequence times from 0, kept before any shift so that times.txt is exact (0.1, not 0.0999999
  // after adding and removing 1.6e9 s).
  s.rel_stamps.clear();
  for (double t : traj.stamps) s.rel_stamps.push_back(t - traj.stamps.front());
  if (tc.type != "tum" && !traj.empty()) {
    const double shift = tc.start_time - traj.stamps.front();
    for (double& t : traj.stamps) t += shift;
  }
  traj = traj.head(cfg_.frames);
  if (s.rel_stamps.size() > traj.size()) s.rel_stamps.resize(traj.size());
  if (traj.empty()) throw ConfigError(traj.source + ": the trajectory has no poses");
  // Every sensor position must be inside the modelled region.
  const auto& B = s.scene.bounds;
  for (std::size_t k = 0; k < traj.size(); ++k) {
    const Eigen::Vector3d p = traj.poses[k].translation();
    if (!B.contains(p)) {
      std::ostringstream os;
      os << std::fixed << std::setprecision(2) << traj.source
         << ": the trajectory leaves the scene at pose " << k << " (t = " << traj.stamps[k]
         << " s): position (" << p.x() << ", " << p.y() << ", " << p.z()
         << ") is outside the scene bounds (" << B.min().x() << ", " << B.min().y() << ", "
         << B.min().z() << ") – (" << B.max().x() << ", " << B.max().y() << ", " << B.max().z()
         << ") of " << s.scene.description;
      throw ConfigError(os.str());
    }
  }
  s.traj = std::move(traj);
  RaycastSceneOptions ro;
  ro.build_threads = cfg_.threads;
  s.rc = std::make_unique<RaycastScene>(s.scene.mesh, ro);
  s.prepared = true;
  OBM_LOG_INFO("sim", cfg_.name << ": " << s.traj.size() << " frames, " << std::fixed
                                << std::setprecision(1) << s.traj.length() << " m, "
                                << s.traj.stamps.back() - s.traj.stamps.front() << " s");
}

namespace {

std::string stampName(double t) {
  char buf[64];
  std::snprintf(buf, sizeof buf, "%.6f", t);
  return buf;
}

// Removes a temporary output folder unless committed.
struct TempDir {
  std::string path;
  bool committed = false;
  ~TempDir() {
    if (!committed && !path.empty()) {
      std::error_code ec;
      fs::remove_all(path, ec);
    }
  }
};

std::string fmtPose(const Eigen::Isometry3d& T) {
  std::ostringstream os;
  os << std::setprecision(9) << "[";
  const auto v = toRowMajor3x4(T);
  for (std::size_t i = 0; i < v.size(); ++i) os << (i ? ", " : "") << v[i];
  os << "]";
  return os.str();
}

}  // namespace

SimSummary SequenceSimulator::run(const SimOptions& opt) {
  Timer total;
  prepare();
  State& s = *st_;
  const SimConfig& C = cfg_;
  const bool lidar = C.sensor.type == "lidar";
  if (opt.out_dir.empty()) throw ConfigError("--out: no output folder given");
  const fs::path dest = fs::absolute(opt.out_dir).lexically_normal();
  const fs::path dest_clean = dest.filename().empty() ? dest.parent_path() : dest;
  std::error_code ec;
  if (fs::exists(dest_clean, ec)) {
    if (!fs::is_directory(dest_clean))
      throw IoError("output '" + dest_clean.string() + "' exists and is not a folder");
    if (!fs::is_empty(dest_clean) && !opt.overwrite)
      throw IoError("output folder '" + dest_clean.string() +
                    "' exists and is not empty (choose another folder or pass --overwrite)");
  }
  ensureDirectory(dest_clean.parent_path().string());
  std::string templ = dest_clean.string() + ".tmp-XXXXXX";
  std::vector<char> buf(templ.begin(), templ.end());
  buf.push_back('\0');
  if (!::mkdtemp(buf.data()))
    throw IoError("cannot create a temporary folder next to '" + dest_clean.string() + "'");
  TempDir tmp{buf.data()};
  const fs::path T(tmp.path);

  const std::size_t n = s.traj.size();
  std::unique_ptr<LidarSimulator> lsim;
  std::unique_ptr<RgbdSimulator> csim;
  if (lidar)
    lsim = std::make_unique<LidarSimulator>(C.sensor.lidar);
  else
    csim = std::make_unique<RgbdSimulator>(C.sensor.rgbd);
  const std::string label = !C.output.sensor_label.empty() ? C.output.sensor_label
                            : lidar                        ? "VELODYNE"
                                                           : "KINECT";
  OutputConfig out_cfg = C.output;
  if (opt.preview_only) out_cfg.rawlog = out_cfg.dataset = false, out_cfg.pictures = true;
  std::unique_ptr<io::RawlogWriter> rawlog;
  if (out_cfg.rawlog)
    rawlog = std::make_unique<io::RawlogWriter>((T / "sequence.rawlog").string(),
                                                C.output.rawlog_compression);
  if (out_cfg.dataset) {
    if (lidar)
      ensureDirectory((T / "velodyne").string());
    else {
      ensureDirectory((T / "depth").string());
      if (C.sensor.rgbd.color) ensureDirectory((T / "rgb").string());
    }
  }
  io::PinholeIntrinsics K;
  K.width = C.sensor.rgbd.width;
  K.height = C.sensor.rgbd.height;
  K.fx = C.sensor.rgbd.fx;
  K.fy = C.sensor.rgbd.fy;
  K.cx = C.sensor.rgbd.cx;
  K.cy = C.sensor.rgbd.cy;
  std::vector<io::StampedFile> depth_list, rgb_list;

  ProgressBar bar(n, C.name, "frames");
  bar.setEnabled(opt.progress);
  const std::size_t pic_frame = n / 2;
  SimSummary sum;
  double t_sensor = 0.0, t_write = 0.0;
  const PoseAtTime pose = [&](double t) { return s.traj.interpolate(t); };
  // Files are written by two background threads while the next frame is ray cast: one keeps
  // the rawlog in order, the other writes the per-frame dataset files.
  detail::WorkQueue rawlog_q(3), files_q(3);
  std::atomic<long long> write_us{0};
  auto timed = [&write_us](std::function<void()> f) {
    return [f = std::move(f), &write_us] {
      Timer tw;
      f();
      write_us += static_cast<long long>(1e6 * tw.seconds());
    };
  };
  const std::size_t k_begin = opt.preview_only ? pic_frame : 0,
                    k_end = opt.preview_only ? pic_frame + 1 : n;
  for (std::size_t k = k_begin; k < k_end; ++k) {
    if (opt.cancel && opt.cancel->load())
      throw Cancelled("interrupted at frame " + std::to_string(k));
    const double t = s.traj.stamps[k];
    const std::uint64_t seed = hashSeed(C.seed, 0x5e45, k);
    Timer tm;
    if (lidar) {
      auto sweep = std::make_shared<const LidarSweep>(
          C.sensor.lidar.motion_distortion ? lsim->simulate(*s.rc, pose, t, seed)
                                           : lsim->simulate(*s.rc, s.traj.poses[k], t, seed));
      t_sensor += tm.seconds();
      sum.points += sweep->cloud.size();
      if (out_cfg.dataset) {
        const std::string path = (T / "velodyne" / io::kittiScanFileName(k)).string();
        files_q.push(timed([sweep, path] { io::writeKittiVelodyne(path, sweep->cloud); }));
      }
      if (rawlog) {
        io::RawlogWriter* rw = rawlog.get();
        rawlog_q.push(timed([sweep, rw, t, label] {
          rw->writePointCloud(sweep->cloud, Eigen::Isometry3d::Identity(), t, label);
        }));
      }
      if (out_cfg.pictures && k == pic_frame) {
        const std::string path = (T / "preview_frame.png").string();
        const std::size_t rings = C.sensor.lidar.ringElevations().size(),
                          cols = C.sensor.lidar.columns();
        files_q.push(timed([sweep, path, rings, cols] {
          writePng(path, renderSweep(*sweep, rings, cols, 50.0, 800));
        }));
      }
    } else {
      auto f = std::make_shared<const DepthFrame>(csim->render(*s.rc, s.traj.poses[k], t, seed));
      t_sensor += tm.seconds();
      auto d = std::make_shared<io::DepthImage>();
      d->width = f->width;
      d->height = f->height;
      d->data.resize(f->depth.size());
      for (std::size_t i = 0; i < f->depth.size(); ++i) {
        const double v = std::round(f->depth[i] * C.output.depth_scale);
        d->data[i] = static_cast<std::uint16_t>(std::clamp(v, 0.0, 65535.0));
        if (f->depth[i] > 0.f) ++sum.points;
      }
      const std::string name = stampName(t) + ".png";
      if (out_cfg.dataset) {
        const std::string dpath = (T / "depth" / name).string();
        files_q.push(timed([d, dpath] { io::writeDepthPng(dpath, *d); }));
        depth_list.push_back({t, "depth/" + name});
        if (!f->rgb.empty()) {
          const std::string cpath = (T / "rgb" / name).string();
          rawlog_q.push(timed([f, cpath] {  // balance the two queues: colour goes with the rawlog
            io::ColorImage c;
            c.width = f->width;
            c.height = f->height;
            c.rgb = f->rgb;
            io::writeColorPng(cpath, c);
          }));
          rgb_list.push_back({t, "rgb/" + name});
        }
      }
      if (rawlog) {
        io::RawlogWriter* rw = rawlog.get();
        const double scale = C.output.depth_scale;
        rawlog_q.push(timed([d, rw, scale, K, t, label] {
          rw->writeDepth(*d, scale, K, Eigen::Isometry3d::Identity(), t, label);
        }));
      }
      if (out_cfg.pictures && k == pic_frame) {
        const std::string path = (T / "preview_frame.png").string();
        const double maxd = C.sensor.rgbd.max_depth;
        files_q.push(timed([f, path, maxd] { writePng(path, renderDepthFrame(*f, maxd)); }));
      }
    }
    bar.update(k + 1);
  }
  rawlog_q.finish();
  files_q.finish();
  t_write = 1e-6 * static_cast<double>(write_us.load());
  bar.finish();
  if (opt.cancel && opt.cancel->load()) throw Cancelled("interrupted");

  // Ground truth and dataset metadata.
  const auto& P = s.traj.poses;
  std::vector<double> rel_t;
  std::vector<Eigen::Isometry3d> rel;
  for (std::size_t k = 0; k < n; ++k) {
    rel_t.push_back(s.rel_stamps[k]);
    // The first pose is the identity exactly (not up to round-off), as in KITTI's files.
    rel.push_back(k == 0 ? Eigen::Isometry3d::Identity() : P.front().inverse() * P[k]);
  }
  if (out_cfg.dataset) {
    if (lidar) {
      auto cam = io::lidarToCameraPoses(rel, s.T_cam0_velo);
      cam.front() = Eigen::Isometry3d::Identity();
      io::writeKittiPoses((T / "poses.txt").string(), cam);
      io::writeKittiTimes((T / "times.txt").string(), rel_t);
      io::KittiCalib calib;
      const KittiCalibration k00 = KittiCalibration::kitti00();
      for (int r = 0; r < 3; ++r)
        for (int c = 0; c < 4; ++c) calib.P0(r, c) = k00.P[0][4 * r + c];
      calib.has_P0 = true;
      calib.T_cam0_velo = s.T_cam0_velo;
      io::writeKittiCalib((T / "calib.txt").string(), calib);
      // Stamped like the rawlog (times.txt holds the same stamps minus the first).
      io::writeTumTrajectory((T / "groundtruth.txt").string(), io::stampPoses(rel, s.traj.stamps));
    } else {
      io::writeTumFileList((T / "depth.txt").string(), depth_list, "timestamp filename");
      if (!rgb_list.empty())
        io::writeTumFileList((T / "rgb.txt").string(), rgb_list, "timestamp filename");
      io::writeTumTrajectory((T / "groundtruth.txt").string(), io::stampPoses(P, s.traj.stamps));
      io::writeKittiPoses((T / "poses.txt").string(), rel);
      io::writeKittiTimes((T / "times.txt").string(), rel_t);
      io::writeOpen3dIntrinsics((T / "camera_intrinsic.json").string(), K);
    }
  }
  if (out_cfg.pictures) {
    const auto& B = s.scene.bounds;
    const bool indoor = C.scene.type == "indoor_floor" || C.scene.type == "indoor_room";
    Eigen::AlignedBox3d region = B;
    const double z_top = B.max().z() + (indoor ? 0.5 : 1.0);
    writePng((T / "preview_topview.png").string(),
             renderTopView(*s.rc, region, z_top, s.traj, 1200, C.threads));
  }
  if (rawlog) rawlog->close();

  sum.frames = n;
  sum.length_m = s.traj.length();
  sum.sensor_seconds = t_sensor;
  sum.scene = s.scene.description;
  {
    std::ostringstream y;
    y << std::setprecision(10);
    y << "# Written by obm-sim: what this folder holds and how it was generated.\n";
    y << "generator: obm-sim\n";
    y << "preset: " << C.name << "\n";
    y << "config: \"" << C.source << "\"\n";
    y << "seed: " << C.seed << "\n";
    y << "frames: " << n << "\n";
    y << "sensor: " << C.sensor.type << "\n";
    y << "rate_hz: " << C.sensor.rate() << "\n";
    y << "layout: " << C.output.format << "\n";
    if (opt.preview_only) y << "preview_only: true  # pictures only, no dataset files\n";
    y << "scene: \"" << s.scene.description << "\"\n";
    y << "trajectory: \"" << s.traj.source << "\"\n";
    y << "trajectory_length_m: " << sum.length_m << "\n";
    y << "duration_s: " << (s.traj.stamps.back() - s.traj.stamps.front()) << "\n";
    y << "points_total: " << sum.points << "\n";
    y << "# Pose of the first frame's sensor in the scene frame (row-major 3x4), "
         "T_scene_sensor0:\n";
    y << "T_scene_sensor0: " << fmtPose(P.front()) << "\n";
    if (lidar) {
      y << "# Frames: velodyne/*.bin and groundtruth.txt in the LiDAR frame (x fwd, y left, z "
           "up);\n";
      y << "# poses.txt in the camera-0 frame, T_cam0_0_cam0_i = Tr * T_lidar0_lidar_i * Tr^-1.\n";
      y << "Tr: " << fmtPose(s.T_cam0_velo) << "\n";
      y << "lidar_rings: " << C.sensor.lidar.ringElevations().size() << "\n";
      y << "lidar_columns: " << C.sensor.lidar.columns() << "\n";
      y << "motion_distortion: " << (C.sensor.lidar.motion_distortion ? "true" : "false") << "\n";
    } else {
      y << "# Frames: groundtruth.txt is T_world_camera (optical frame: x right, y down, z fwd);\n";
      y << "# poses.txt is the same relative to the first frame. Depth PNG: depth_scale units/m.\n";
      y << "depth_scale: " << C.output.depth_scale << "\n";
      y << "intrinsics: {width: " << K.width << ", height: " << K.height << ", fx: " << K.fx
        << ", fy: " << K.fy << ", cx: " << K.cx << ", cy: " << K.cy << "}\n";
    }
    y << "timing_s: {sensor: " << t_sensor << ", write: " << t_write
      << ", total: " << total.seconds() << "}\n";
    writeTextAtomically((T / "sim_info.yaml").string(), y.str());
  }

  // Commit: move any previous destination aside, rename the temporary folder into place.
  if (fs::exists(dest_clean)) {
    const std::string old = dest_clean.string() + ".old-" + std::to_string(::getpid());
    fs::rename(dest_clean, old);
    try {
      fs::rename(T, dest_clean);
    } catch (...) {
      fs::rename(old, dest_clean);
      throw;
    }
    tmp.committed = true;
    fs::remove_all(old, ec);
  } else {
    fs::rename(T, dest_clean);
    tmp.committed = true;
  }
  sum.out_dir = dest_clean.string();
  sum.seconds = total.seconds();
  OBM_LOG_INFO("sim", "wrote " << n << " frames to " << sum.out_dir << " in " << std::fixed
                               << std::setprecision(1) << sum.seconds << " s (sensor " << t_sensor
                               << " s, writing " << t_write << " s)");
  return sum;
}

}  // namespace obm::sim
