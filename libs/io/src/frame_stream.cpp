#include "obm/io/frame_stream.hpp"

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <limits>
#include <sstream>

#include "obm/core/errors.hpp"
#include "obm/core/log.hpp"
#include "obm/io/rawlog.hpp"
#include "obm/io/rgbd.hpp"
#include "obm/io/trajectory.hpp"

namespace fs = std::filesystem;

namespace obm::io {

namespace {

/// Number of numbers on the first non-comment line of a trajectory file (12 = KITTI, 8 = TUM).
std::size_t columnsOfFirstPose(const std::string& path) {
  std::ifstream in(path);
  if (!in) throw IoError("cannot open ground-truth file '" + path + "'");
  std::string line;
  std::size_t line_no = 0;
  while (std::getline(in, line)) {
    ++line_no;
    const auto first = line.find_first_not_of(" \t\r");
    if (first == std::string::npos || line[first] == '#') continue;
    for (char& c : line)
      if (c == ',') c = ' ';
    std::istringstream is(line);
    std::size_t n = 0;
    std::string tok;
    while (is >> tok) ++n;
    if (n != 8 && n != 12)
      throw FormatError(path, line_no,
                        "expected a TUM (8 numbers) or KITTI (12 numbers) pose line, found " +
                            std::to_string(n) + " fields");
    return n;
  }
  throw FormatError(path, 0, "no pose line");
}

/// A trajectory file as per-frame ground truth: KITTI files are index-aligned, TUM files are
/// associated by time stamp.
FrameGroundTruth groundTruthFromFile(const std::string& path, const std::vector<double>& timestamps,
                                double max_dt) {
  FrameGroundTruth gt;
  gt.path = path;
  gt.T_world_body.assign(timestamps.size(), std::nullopt);
  if (columnsOfFirstPose(path) == 12) {
    const auto poses = readKittiTrajectory(path);
    for (std::size_t i = 0; i < timestamps.size() && i < poses.size(); ++i)
      gt.T_world_body[i] = poses[i];
  } else {
    const Trajectory traj = readTumTrajectory(path);
    const auto matches = associateTimestamps(timestamps, timestampsOf(traj), max_dt);
    for (const auto& m : matches) gt.T_world_body[m.first] = traj[m.second].T;
  }
  return gt;
}

// --- KITTI -----------------------------------------------------------------------------------

class KittiSource : public FrameStream {
 public:
  KittiSource(const std::string& dir, const FrameStreamOptions& p)
      : seq_(dir, p.ground_truth), p_(p) {}
  DatasetKind kind() const override { return DatasetKind::Kitti; }
  std::size_t size() const override { return seq_.size(); }
  std::vector<double> timestamps() const override { return seq_.timestamps(); }
  bool skip() override {
    if (i_ >= seq_.size()) return false;
    ++i_;
    return true;
  }
  bool next(PointCloud& cloud) override {
    if (i_ >= seq_.size()) return false;
    try {
      cloud = seq_.scan(i_);
    } catch (const Error& e) {
      // A corrupt scan file is a counted skip: the front-end bridges an empty sweep.
      ++read_errors_;
      OBM_LOG_WARN(p_.log_component.c_str(), "frame " << i_ << ": " << e.what() << " (skipped)");
      cloud = PointCloud();
      cloud.frame_id = "velodyne";
    }
    cloud.timestamp = seq_.timestamp(i_);
    ++i_;
    return true;
  }
  const KittiCalib* kittiCalib() const override { return &seq_.calib(); }
  FrameGroundTruth groundTruth(const std::vector<double>& timestamps, double) const override {
    FrameGroundTruth gt;
    gt.T_world_body.assign(timestamps.size(), std::nullopt);
    if (!seq_.hasGroundTruth()) return gt;
    gt.path = seq_.groundTruthPath();
    const auto& lidar = seq_.groundTruthLidar();
    for (std::size_t i = 0; i < timestamps.size() && i < lidar.size(); ++i)
      gt.T_world_body[i] = lidar[i];
    return gt;
  }

 private:
  KittiSequence seq_;
  FrameStreamOptions p_;
  std::size_t i_ = 0;
};

// --- RGB-D -----------------------------------------------------------------------------------

class RgbdSource : public FrameStream {
 public:
  RgbdSource(RgbdSequence seq, DatasetKind kind, const FrameStreamOptions& p)
      : seq_(std::move(seq)), kind_(kind), p_(p) {
    // 7-Scenes' colour camera is not registered to its depth camera: pixel (u, v) of one is not
    // pixel (u, v) of the other, so its colours would be attached to the wrong points.
    if (kind == DatasetKind::SevenScenes && p_.rgbd_color) {
      OBM_LOG_WARN(p_.log_component.c_str(), "7-Scenes: colour is not registered to depth; frames used without colour");
      p_.rgbd_color = false;
    }
    if (p_.rgbd_color && std::none_of(seq_.frames().begin(), seq_.frames().end(),
                                      [](const RgbdFrame& f) { return !f.color_path.empty(); })) {
      OBM_LOG_WARN(p_.log_component.c_str(), seq_.directory()
                                                 << ": no frame has a colour image; frames used "
                                                    "without colour");
      p_.rgbd_color = false;
    }
  }
  DatasetKind kind() const override { return kind_; }
  std::size_t size() const override { return seq_.size(); }
  std::vector<double> timestamps() const override {
    std::vector<double> t;
    t.reserve(seq_.size());
    for (const auto& f : seq_.frames()) t.push_back(f.timestamp);
    return t;
  }
  bool skip() override {
    if (i_ >= seq_.size()) return false;
    ++i_;
    return true;
  }
  bool next(PointCloud& cloud) override {
    if (i_ >= seq_.size()) return false;
    const double max_depth =
        p_.depth_max > 0.0 ? p_.depth_max : std::numeric_limits<double>::infinity();
    try {
      bool color = p_.rgbd_color && !seq_.frame(i_).color_path.empty();
      if (p_.rgbd_color && !color)
        OBM_LOG_WARN(p_.log_component.c_str(), "frame " << i_ << ": no colour image (used without colour)");
      if (color) {
        try {
          cloud = seq_.cloud(i_, p_.depth_min, max_depth, p_.rgbd_stride, true,
                             p_.rgbd_edge_jump);
        } catch (const Error& e) {
          // A colour image that cannot be read (or is not registered to the depth) costs the
          // photometric term of one frame, not the frame.
          OBM_LOG_WARN(p_.log_component.c_str(), "frame " << i_ << ": " << e.what() << " (used without colour)");
          color = false;
        }
      }
      if (!color)
        cloud = seq_.cloud(i_, p_.depth_min, max_depth, p_.rgbd_stride, false, p_.rgbd_edge_jump);
    } catch (const Error& e) {
      ++read_errors_;
      OBM_LOG_WARN(p_.log_component.c_str(), "frame " << i_ << ": " << e.what() << " (skipped)");
      cloud = PointCloud();
      cloud.frame_id = "camera";
    }
    cloud.timestamp = seq_.frame(i_).timestamp;
    ++i_;
    return true;
  }
  Isometry3d T_up_sensor() const override {
    Isometry3d T = Isometry3d::Identity();
    T.linear() = T_mrptCamera_optical().linear();
    return T;
  }
  FrameGroundTruth groundTruth(const std::vector<double>& timestamps, double) const override {
    FrameGroundTruth gt;
    gt.T_world_body.assign(timestamps.size(), std::nullopt);
    bool any = false;
    for (std::size_t i = 0; i < timestamps.size() && i < seq_.size(); ++i)
      if (seq_.frame(i).has_pose) {
        gt.T_world_body[i] = seq_.frame(i).T_world_camera;
        any = true;
      }
    if (any) gt.path = seq_.directory() + " (ground truth of the layout)";
    return gt;
  }

 private:
  RgbdSequence seq_;
  DatasetKind kind_;
  FrameStreamOptions p_;
  std::size_t i_ = 0;
};

// --- rawlog ----------------------------------------------------------------------------------

class RawlogSource : public FrameStream {
 public:
  RawlogSource(const std::string& path, std::string gt, const FrameStreamOptions& p)
      : path_(path), gt_(std::move(gt)), p_(p), reader_(path, readOptions(p)) {
    if (gt_.empty()) {
      const fs::path next_to = fs::path(path).parent_path() / "groundtruth.txt";
      if (fs::is_regular_file(next_to)) gt_ = next_to.string();
    }
  }
  DatasetKind kind() const override { return DatasetKind::Rawlog; }
  std::size_t size() const override { return 0; }
  std::vector<double> timestamps() const override {
    // A pass over the metadata: the observations next() plays, without their clouds.
    RawlogReadOptions meta = readOptions(p_);
    meta.generate_clouds = false;
    RawlogReader reader(path_, meta);
    RawlogObservation obs;
    std::vector<double> t;
    while (reader.next(obs))
      if (p_.sensor_label.empty() || obs.sensor_label == p_.sensor_label) t.push_back(obs.timestamp);
    return t;
  }
  bool next(PointCloud& cloud) override {
    if (ended_) return false;
    RawlogObservation obs;
    while (true) {
      bool at_end = false;
      try {
        at_end = !reader_.next(obs);
      } catch (const FormatError& e) {
        // A truncated or corrupt rawlog cannot be read past the damage: stop there.
        ++read_errors_;
        OBM_LOG_WARN(p_.log_component.c_str(), e.what() << " — stopping at the last readable observation");
        ended_ = true;
        return false;
      }
      if (at_end) {
        ended_ = true;
        reportSkipped();  // outside the try: "nothing to play" is not a damaged file
        return false;
      }
      if (!p_.sensor_label.empty() && obs.sensor_label != p_.sensor_label) {
        ++other_labels_;
        continue;
      }
      break;
    }
    if (first_) {
      first_ = false;
      if (obs.has_depth) {
        // Map "up" for a depth camera: the first camera's x-forward / z-up frame.
        up_ = Isometry3d::Identity();
        up_.linear() = (T_mrptCamera_optical() * obs.T_vehicle_camera.inverse()).linear();
      }
    }
    cloud = std::move(obs.cloud);
    cloud.timestamp = obs.timestamp;
    return true;
  }
  Isometry3d T_up_sensor() const override { return up_; }
  FrameGroundTruth groundTruth(const std::vector<double>& timestamps, double max_dt) const override {
    if (gt_.empty()) {
      FrameGroundTruth gt;
      gt.T_world_body.assign(timestamps.size(), std::nullopt);
      return gt;
    }
    return groundTruthFromFile(gt_, timestamps, max_dt);
  }

 private:
  /// At the end of the rawlog: what was not played, and a clear error when nothing was.
  void reportSkipped() const {
    std::string classes;
    for (const auto& [cls, k] : reader_.counts().skipped_by_class)
      classes += (classes.empty() ? "" : ", ") + std::to_string(k) + " " + cls;
    if (first_) {
      throw FormatError(
          path_, 0,
          "no observation obm-map can play" +
              (classes.empty() ? std::string() : " (it holds " + classes + ")") +
              (other_labels_ > 0 ? "; " + std::to_string(other_labels_) +
                                       " observations have another sensor label than input.sensor_label '" +
                                       p_.sensor_label + "'"
                                 : std::string()) +
              ". Played: CObservationPointCloud, CObservationVelodyneScan (MRPT's "
              "generatePointCloud), CObservation3DRangeScan (MRPT's unprojection), "
              "CObservation2DRangeScan. MRPT 2.5's CObservationRotatingScan stores no laser "
              "elevations, so it cannot be turned into points");
    }
    if (!classes.empty())
      OBM_LOG_WARN(p_.log_component.c_str(), path_ << ": skipped observations that are not point clouds: " << classes);
  }

  static RawlogReadOptions readOptions(const FrameStreamOptions& p) {
    RawlogReadOptions o;
    o.velodyne_min_range = p.velodyne_min_range;
    if (p.depth_max > 0.0) o.depth_max = p.depth_max;
    o.depth_min = p.depth_min;
    return o;
  }
  std::string path_, gt_;
  FrameStreamOptions p_;
  RawlogReader reader_;
  bool ended_ = false, first_ = true;
  std::size_t other_labels_ = 0;
  Isometry3d up_ = Isometry3d::Identity();
};

}  // namespace

std::unique_ptr<FrameStream> FrameStream::open(const std::string& input,
                                               const FrameStreamOptions& params) {
  const std::string& ground_truth = params.ground_truth;
  if (!ground_truth.empty() && !fs::is_regular_file(ground_truth))
    throw IoError("ground-truth file '" + ground_truth + "' does not exist");
  const DatasetKind kind = detectDatasetKind(input);
  RgbdSequenceOptions ro;
  ro.max_time_difference = params.max_time_difference;
  ro.groundtruth_path = ground_truth;
  switch (kind) {
    case DatasetKind::Kitti:
      return std::make_unique<KittiSource>(input, params);
    case DatasetKind::TumRgbd:
    case DatasetKind::IclNuim:
    case DatasetKind::SevenScenes:
    case DatasetKind::Redwood:
      return std::make_unique<RgbdSource>(RgbdSequence::open(input, ro), kind, params);
    case DatasetKind::Rawlog:
      return std::make_unique<RawlogSource>(input, ground_truth, params);
  }
  throw IoError("input '" + input + "': unsupported layout");
}

}  // namespace obm::io
