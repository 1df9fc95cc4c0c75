#include "frame_source.hpp"

#include <algorithm>
#include <cctype>
#include <filesystem>
#include <limits>

#include "obm/core/errors.hpp"
#include "obm/io/rawlog.hpp"
#include "obm/io/rgbd.hpp"

namespace obm::mapping::detail {

namespace fs = std::filesystem;

std::string toString(InputKind kind) {
  switch (kind) {
    case InputKind::Kitti:
      return "kitti";
    case InputKind::TumRgbd:
      return "tum-rgbd";
    case InputKind::IclNuim:
      return "icl-nuim";
    case InputKind::SevenScenes:
      return "7scenes";
    case InputKind::Redwood:
      return "redwood";
    case InputKind::Rawlog:
      return "rawlog";
  }
  return "unknown";
}

InputKind detectInputKind(const std::string& input) {
  const fs::path p(input);
  if (!fs::exists(p)) throw IoError("input '" + input + "' does not exist");
  if (fs::is_regular_file(p)) return InputKind::Rawlog;
  if (!fs::is_directory(p)) throw IoError("input '" + input + "' is neither a folder nor a file");
  if (fs::is_directory(p / "velodyne")) return InputKind::Kitti;
  const auto endsWith = [](const std::string& s, const std::string& tail) {
    return s.size() >= tail.size() && s.compare(s.size() - tail.size(), tail.size(), tail) == 0;
  };
  bool seven_scenes = false, icl_ground_truth = false;
  std::error_code ec;
  for (fs::directory_iterator it(p, ec), end; !ec && it != end; it.increment(ec)) {
    const std::string name = it->path().filename().string();
    if (name.rfind("frame-", 0) == 0 && endsWith(name, ".depth.png")) seven_scenes = true;
    if (endsWith(name, ".gt.freiburg")) icl_ground_truth = true;
  }
  // ICL-NUIM's TUM-compatible release also has depth.txt; its *.gt.freiburg file tells it apart
  // (the intrinsics differ from TUM's).
  if (fs::is_regular_file(p / "associations.txt") || icl_ground_truth) return InputKind::IclNuim;
  if (fs::is_regular_file(p / "depth.txt")) return InputKind::TumRgbd;
  if (fs::is_directory(p / "depth")) return InputKind::Redwood;
  if (seven_scenes) return InputKind::SevenScenes;
  throw IoError("input '" + input +
                "': no known layout (expected velodyne/ + calib.txt + times.txt for KITTI; "
                "depth.txt, associations.txt, frame-*.depth.png or depth/ for RGB-D; or a "
                ".rawlog file)");
}

namespace {

class KittiSource : public FrameSource {
 public:
  KittiSource(const std::string& dir, const std::string& poses_path) : seq_(dir, poses_path) {}
  InputKind kind() const override { return InputKind::Kitti; }
  std::size_t size() const override { return seq_.size(); }
  const std::vector<double>& timestamps() const override { return seq_.timestamps(); }
  const io::KittiCalib* kittiCalib() const override { return &seq_.calib(); }
  PointCloud cloud(std::size_t i, bool) override { return seq_.scan(i); }

 private:
  io::KittiSequence seq_;
};

bool endsWithPng(const std::string& path) {
  std::string ext = fs::path(path).extension().string();
  std::transform(ext.begin(), ext.end(), ext.begin(),
                 [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  return ext == ".png";
}

class RgbdSource : public FrameSource {
 public:
  RgbdSource(io::RgbdSequence seq, InputKind kind, double max_depth)
      : seq_(std::move(seq)), kind_(kind), max_depth_(max_depth) {
    for (const auto& f : seq_.frames()) times_.push_back(f.timestamp);
    // 7-Scenes colour is not registered to depth; elsewhere colour needs PNG images (no JPEG).
    has_color_ = kind_ != InputKind::SevenScenes && seq_.size() > 0 &&
                 std::all_of(seq_.frames().begin(), seq_.frames().end(), [](const auto& f) {
                   return !f.color_path.empty() && endsWithPng(f.color_path);
                 });
  }
  InputKind kind() const override { return kind_; }
  std::size_t size() const override { return seq_.size(); }
  const std::vector<double>& timestamps() const override { return times_; }
  PointCloud cloud(std::size_t i, bool with_color) override {
    const double max_d = max_depth_ > 0.0 ? max_depth_ : std::numeric_limits<double>::infinity();
    return seq_.cloud(i, 0.0, max_d, 1, with_color && has_color_);
  }

 private:
  io::RgbdSequence seq_;
  InputKind kind_;
  double max_depth_;
  std::vector<double> times_;
  bool has_color_ = false;
};

class RawlogSource : public FrameSource {
 public:
  explicit RawlogSource(const std::string& path) : path_(path) {
    // A first pass over the metadata gives the time stamps to associate poses with; clouds are
    // generated in the second, streamed pass.
    io::RawlogReadOptions meta;
    meta.generate_clouds = false;
    io::RawlogReader reader(path, meta);
    io::RawlogObservation obs;
    while (reader.next(obs)) times_.push_back(obs.timestamp);
    if (times_.empty())
      throw FormatError(path, 0, "the rawlog holds no observation that gives points");
    reader_ = std::make_unique<io::RawlogReader>(path);
  }
  InputKind kind() const override { return InputKind::Rawlog; }
  std::size_t size() const override { return times_.size(); }
  const std::vector<double>& timestamps() const override { return times_; }
  PointCloud cloud(std::size_t i, bool) override {
    if (i < next_)
      throw ContractError("rawlog frames must be read in increasing order ('" + path_ + "')");
    io::RawlogObservation obs;
    while (next_ <= i) {
      if (!reader_->next(obs))
        throw FormatError(path_, 0,
                          "observation " + std::to_string(i) + " is missing in the second pass");
      ++next_;
    }
    return std::move(obs.cloud);
  }

 private:
  std::string path_;
  std::vector<double> times_;
  std::unique_ptr<io::RawlogReader> reader_;
  std::size_t next_ = 0;
};

}  // namespace

std::unique_ptr<FrameSource> openFrameSource(const std::string& input, InputKind kind,
                                             const std::string& kitti_poses_path,
                                             double rgbd_max_depth) {
  switch (kind) {
    case InputKind::Kitti:
      return std::make_unique<KittiSource>(input, kitti_poses_path);
    case InputKind::TumRgbd:
      return std::make_unique<RgbdSource>(io::RgbdSequence::openTum(input), kind, rgbd_max_depth);
    case InputKind::IclNuim:
      return std::make_unique<RgbdSource>(io::RgbdSequence::openIclNuim(input), kind,
                                          rgbd_max_depth);
    case InputKind::SevenScenes:
      return std::make_unique<RgbdSource>(io::RgbdSequence::open7Scenes(input), kind,
                                          rgbd_max_depth);
    case InputKind::Redwood:
      return std::make_unique<RgbdSource>(io::RgbdSequence::openRedwood(input), kind,
                                          rgbd_max_depth);
    case InputKind::Rawlog:
      return std::make_unique<RawlogSource>(input);
  }
  throw ContractError("openFrameSource: unknown input kind");
}

}  // namespace obm::mapping::detail
