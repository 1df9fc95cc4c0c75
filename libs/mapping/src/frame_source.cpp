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
    case InputKind::IclNuim:
    case InputKind::SevenScenes:
    case InputKind::Redwood:
      return std::make_unique<RgbdSource>(io::RgbdSequence::open(input), kind, rgbd_max_depth);
    case InputKind::Rawlog:
      return std::make_unique<RawlogSource>(input);
  }
  throw ContractError("openFrameSource: unknown input kind");
}

}  // namespace obm::mapping::detail
