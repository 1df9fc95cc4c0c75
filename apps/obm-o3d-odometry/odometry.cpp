// obm-o3d-odometry's work through Open3D 0.16 (Debian libopen3d-dev): frame-to-frame RGB-D
// odometry (hybrid or photometric term) or coloured ICP, chained into a trajectory.
#include "odometry.hpp"

#include <open3d/camera/PinholeCameraIntrinsic.h>
#include <open3d/geometry/Image.h>
#include <open3d/geometry/KDTreeSearchParam.h>
#include <open3d/geometry/PointCloud.h>
#include <open3d/geometry/RGBDImage.h>
#include <open3d/io/ImageIO.h>
#include <open3d/pipelines/odometry/Odometry.h>
#include <open3d/pipelines/odometry/OdometryOption.h>
#include <open3d/pipelines/odometry/RGBDOdometryJacobian.h>
#include <open3d/pipelines/registration/ColoredICP.h>
#include <open3d/pipelines/registration/Registration.h>
#include <open3d/utility/Logging.h>

#include <cstdint>
#include <cstring>
#include <exception>
#include <filesystem>
#include <fstream>
#include <memory>
#include <sstream>
#include <tuple>
#include <utility>

#include "obm/core/errors.hpp"
#include "obm/core/progress.hpp"
#include "obm/core/timer.hpp"

namespace obm::o3d {

namespace fs = std::filesystem;
namespace geo = open3d::geometry;
namespace odo = open3d::pipelines::odometry;
namespace reg = open3d::pipelines::registration;

namespace {

constexpr const char* kLog = "o3d-odometry";
/// Fewer points than this in a level of coloured ICP: the level is not run.
constexpr std::size_t kMinLevelPoints = 20;
/// Coloured ICP: a down-sampled point needs this many neighbours within two voxels to be kept.
constexpr std::size_t kMinNeighbours = 6;

std::string frameName(std::size_t i, const io::RgbdFrame& f) {
  std::ostringstream os;
  os << "frame " << i << " (t = " << f.timestamp << " s)";
  return os.str();
}

std::shared_ptr<geo::Image> readImage(const std::string& path, const char* what,
                                      const std::string& frame) {
  if (path.empty()) throw IoError(frame + ": no " + what + " image associated with it");
  if (!fs::is_regular_file(path))
    throw IoError(frame + ": " + what + " image '" + path + "' does not exist");
  // Open3D hands JPEG files to libjpeg, whose default error handler ends the process on a file
  // that is not a JPEG: the signature is checked here first so that the error names the frame.
  unsigned char magic[4] = {0, 0, 0, 0};
  {
    std::ifstream in(path, std::ios::binary);
    in.read(reinterpret_cast<char*>(magic), sizeof magic);
    if (!in) throw IoError(frame + ": cannot read " + what + " image '" + path + "'");
  }
  const bool png = magic[0] == 0x89 && magic[1] == 'P' && magic[2] == 'N' && magic[3] == 'G';
  const bool jpeg = magic[0] == 0xFF && magic[1] == 0xD8 && magic[2] == 0xFF;
  if (!png && !jpeg)
    throw FormatError(path, 0, frame + ": the " + what + " image is neither a PNG nor a JPEG file");
  std::shared_ptr<geo::Image> img;
  try {
    img = open3d::io::CreateImageFromFile(path);
  } catch (const std::exception& e) {
    throw IoError(frame + ": cannot read " + what + " image '" + path + "': " + e.what());
  }
  if (!img || img->IsEmpty())
    throw IoError(frame + ": cannot read " + what + " image '" + path +
                  "' (Open3D reads PNG and JPEG)");
  return img;
}

/// An 8-bit colour image as 3 channels (grey replicated, alpha dropped).
std::shared_ptr<geo::Image> toRgb(std::shared_ptr<geo::Image> img, const std::string& path,
                                  const std::string& frame) {
  const int c = img->num_of_channels_;
  if (img->bytes_per_channel_ != 1 || (c != 1 && c != 3 && c != 4))
    throw FormatError(path, 0,
                      frame + ": the colour image must have 8-bit channels (grey, RGB or RGBA), "
                              "got " +
                          std::to_string(c) + " channel(s) of " +
                          std::to_string(8 * img->bytes_per_channel_) + " bits");
  if (c == 3) return img;
  auto out = std::make_shared<geo::Image>();
  out->Prepare(img->width_, img->height_, 3, 1);
  const std::size_t n = static_cast<std::size_t>(img->width_) * img->height_;
  const std::uint8_t* src = img->data_.data();
  std::uint8_t* dst = out->data_.data();
  for (std::size_t k = 0; k < n; ++k)
    for (int j = 0; j < 3; ++j) dst[3 * k + j] = src[c * k + (c == 1 ? 0 : j)];
  return out;
}

bool finite(const Eigen::Matrix4d& M) { return M.allFinite(); }

Isometry3d toIso(const Eigen::Matrix4d& M) {
  Isometry3d T = Isometry3d::Identity();
  T.matrix() = M;
  // Re-orthonormalise: chaining thousands of products must not let the rotation drift.
  const Eigen::Quaterniond q(T.linear());
  T.linear() = q.normalized().toRotationMatrix();
  return T;
}

/// One frame as the estimators need it.
struct Frame {
  std::shared_ptr<geo::RGBDImage> rgbd;                  ///< intensity + depth [m] (odometry)
  std::vector<std::shared_ptr<geo::PointCloud>> levels;  ///< coloured ICP, coarse to fine
};

class Estimator {
 public:
  Estimator(const io::RgbdSequence& seq, const OdometryOptions& o)
      : seq_(seq), o_(o), K_(makeIntrinsic(seq.intrinsics())) {
    option_.depth_min_ = o.depth_min;
    option_.depth_max_ = o.depth_max;
  }

  Frame load(std::size_t i) const {
    const io::RgbdFrame& f = seq_.frame(i);
    const std::string name = frameName(i, f);
    auto depth = readImage(f.depth_path, "depth", name);
    if (depth->num_of_channels_ != 1 || depth->bytes_per_channel_ != 2)
      throw FormatError(f.depth_path, 0,
                        name + ": the depth image must be 16-bit single-channel, got " +
                            std::to_string(depth->num_of_channels_) + " channel(s) of " +
                            std::to_string(8 * depth->bytes_per_channel_) + " bits");
    const auto& in = seq_.intrinsics();
    if (depth->width_ != in.width || depth->height_ != in.height)
      throw FormatError(f.depth_path, 0,
                        name + ": depth image is " + std::to_string(depth->width_) + "x" +
                            std::to_string(depth->height_) + ", the intrinsics are for " +
                            std::to_string(in.width) + "x" + std::to_string(in.height));
    auto color = toRgb(readImage(f.color_path, "colour", name + " (depth '" + f.depth_path + "')"),
                       f.color_path, name);
    if (color->width_ != depth->width_ || color->height_ != depth->height_)
      throw FormatError(f.color_path, 0,
                        name + ": colour image is " + std::to_string(color->width_) + "x" +
                            std::to_string(color->height_) + ", its depth image '" +
                            f.depth_path + "' is " + std::to_string(depth->width_) + "x" +
                            std::to_string(depth->height_));

    Frame fr;
    const bool icp = o_.method == Method::ColoredIcp;
    // depth_trunc = depth_max: farther depth becomes 0 (invalid), as Open3D's odometry ignores it.
    fr.rgbd = geo::RGBDImage::CreateFromColorAndDepth(*color, *depth, seq_.depthScale(),
                                                      o_.depth_max, !icp);
    float* d = fr.rgbd->depth_.PointerAs<float>();
    const std::size_t n = static_cast<std::size_t>(fr.rgbd->depth_.width_) *
                          static_cast<std::size_t>(fr.rgbd->depth_.height_);
    for (std::size_t k = 0; k < n; ++k)
      if (d[k] < o_.depth_min) d[k] = 0.0f;
    if (icp) {
      const auto cloud = geo::PointCloud::CreateFromRGBDImage(*fr.rgbd, K_);
      for (double voxel : o_.icp_voxels) {
        // Isolated points (flying pixels at depth edges) are dropped: with fewer neighbours than
        // this the colour gradient Open3D fits around a point is near-singular, and on the real
        // rgbd_open3d frames one such point at the 1 cm level blew the Gauss-Newton step up to
        // 1e17 (no correspondence left after it, every frame failed).
        auto down = std::get<0>(
            cloud->VoxelDownSample(voxel)->RemoveRadiusOutliers(kMinNeighbours, 2.0 * voxel));
        down->EstimateNormals(geo::KDTreeSearchParamHybrid(2.0 * voxel, 30));
        down->OrientNormalsTowardsCameraLocation(Eigen::Vector3d::Zero());
        fr.levels.push_back(std::move(down));
      }
      fr.rgbd.reset();
    }
    return fr;
  }

  /// T_target_source from `guess`; false (and a reason) when the estimator fails.
  bool estimate(const Frame& source, const Frame& target, const Eigen::Matrix4d& guess,
                Eigen::Matrix4d& T, std::string& reason) const {
    try {
      return o_.method == Method::ColoredIcp ? coloredIcp(source, target, guess, T, reason)
                                             : rgbdOdometry(source, target, guess, T, reason);
    } catch (const std::exception& e) {
      reason = std::string("Open3D: ") + e.what();
      return false;
    }
  }

 private:
  static open3d::camera::PinholeCameraIntrinsic makeIntrinsic(const io::PinholeIntrinsics& in) {
    return open3d::camera::PinholeCameraIntrinsic(in.width, in.height, in.fx, in.fy, in.cx, in.cy);
  }

  bool rgbdOdometry(const Frame& source, const Frame& target, const Eigen::Matrix4d& guess,
                    Eigen::Matrix4d& T, std::string& reason) const {
    bool ok = false;
    Eigen::Matrix4d M;
    Eigen::Matrix6d info;
    if (o_.method == Method::Hybrid)
      std::tie(ok, M, info) = odo::ComputeRGBDOdometry(
          *source.rgbd, *target.rgbd, K_, guess, odo::RGBDOdometryJacobianFromHybridTerm(),
          option_);
    else
      std::tie(ok, M, info) = odo::ComputeRGBDOdometry(
          *source.rgbd, *target.rgbd, K_, guess, odo::RGBDOdometryJacobianFromColorTerm(),
          option_);
    if (!ok) {
      reason = "ComputeRGBDOdometry reported no solution";
      return false;
    }
    if (!finite(M)) {
      reason = "ComputeRGBDOdometry returned a non-finite motion";
      return false;
    }
    T = M;
    return true;
  }

  bool coloredIcp(const Frame& source, const Frame& target, const Eigen::Matrix4d& guess,
                  Eigen::Matrix4d& T, std::string& reason) const {
    Eigen::Matrix4d M = guess;
    double fitness = 0.0;
    std::size_t levels_run = 0;
    for (std::size_t k = 0; k < o_.icp_voxels.size(); ++k) {
      const auto& s = *source.levels[k];
      const auto& t = *target.levels[k];
      if (s.points_.size() < kMinLevelPoints || t.points_.size() < kMinLevelPoints) continue;
      const double voxel = o_.icp_voxels[k];
      const reg::RegistrationResult r = reg::RegistrationColoredICP(
          s, t, voxel, M, reg::TransformationEstimationForColoredICP(o_.icp_lambda_geometric),
          reg::ICPConvergenceCriteria(1e-6, 1e-6, o_.icp_iterations[k]));
      if (!finite(r.transformation_)) {
        reason = "coloured ICP at voxel " + std::to_string(voxel) + " m diverged";
        return false;
      }
      M = r.transformation_;
      fitness = r.fitness_;
      ++levels_run;
    }
    if (levels_run == 0) {
      reason = "fewer than " + std::to_string(kMinLevelPoints) +
               " points at every level (no depth in range?)";
      return false;
    }
    if (fitness <= 0.0) {
      reason = "coloured ICP found no correspondence at the finest level";
      return false;
    }
    T = M;
    return true;
  }

  const io::RgbdSequence& seq_;
  const OdometryOptions& o_;
  open3d::camera::PinholeCameraIntrinsic K_;
  odo::OdometryOption option_;  // Open3D's defaults but the depth range
};

}  // namespace

std::string toString(Method method) {
  switch (method) {
    case Method::Hybrid:
      return "hybrid";
    case Method::Color:
      return "color";
    case Method::ColoredIcp:
      return "colored_icp";
  }
  return "?";
}

Method parseMethod(const std::string& text, const std::string& what) {
  for (Method m : {Method::Hybrid, Method::Color, Method::ColoredIcp})
    if (text == toString(m)) return m;
  throw ConfigError(what + ": unknown method '" + text + "' (hybrid, color or colored_icp)");
}

std::string toString(InitGuess init) {
  return init == InitGuess::ConstantVelocity ? "velocity" : "identity";
}

InitGuess parseInitGuess(const std::string& text, const std::string& what) {
  for (InitGuess g : {InitGuess::ConstantVelocity, InitGuess::Identity})
    if (text == toString(g)) return g;
  throw ConfigError(what + ": unknown initial guess '" + text + "' (velocity or identity)");
}

void setOpen3dVerbosity(LogLevel level) {
  using V = open3d::utility::VerbosityLevel;
  open3d::utility::SetVerbosityLevel(level == LogLevel::Debug  ? V::Debug
                                     : level == LogLevel::Info ? V::Warning
                                                               : V::Error);
}

OdometryRun runOdometry(const io::RgbdSequence& seq, const OdometryOptions& o) {
  if (!(o.depth_min >= 0.0 && o.depth_max > o.depth_min))
    throw ConfigError("depth range [" + std::to_string(o.depth_min) + ", " +
                      std::to_string(o.depth_max) + "] m is empty");
  if (o.method == Method::ColoredIcp) {
    if (o.icp_voxels.empty() || o.icp_voxels.size() != o.icp_iterations.size())
      throw ConfigError("coloured ICP needs as many iteration caps as voxel sizes");
    for (std::size_t k = 0; k < o.icp_voxels.size(); ++k)
      if (!(o.icp_voxels[k] > 0.0) || o.icp_iterations[k] < 1)
        throw ConfigError("coloured ICP level " + std::to_string(k) +
                          ": the voxel must be > 0 and the iterations >= 1");
    if (!(o.icp_lambda_geometric >= 0.0 && o.icp_lambda_geometric <= 1.0))
      throw ConfigError("coloured ICP: lambda_geometric must be in [0, 1], got " +
                        std::to_string(o.icp_lambda_geometric));
  }
  std::size_t n = seq.size();
  if (o.max_frames > 0 && o.max_frames < n) n = o.max_frames;

  OdometryRun run;
  const Estimator est(seq, o);
  ProgressBar bar(n, "obm-o3d-odometry", "frames");
  bar.setEnabled(o.progress);
  Frame previous;
  bool have_previous = false;
  std::size_t skipped_since_previous = 0;  // frames between `previous` and this one
  Isometry3d T_world = Isometry3d::Identity();
  Eigen::Matrix4d velocity = Eigen::Matrix4d::Identity();  // T_{i-1}_i of the last frame
  const auto status = [&run] {
    return "failures " + std::to_string(run.failed_frames.size()) + ", skipped " +
           std::to_string(run.skipped_frames.size());
  };
  for (std::size_t i = 0; i < n; ++i) {
    if (o.cancel && o.cancel->load()) {
      run.interrupted = true;
      break;
    }
    Timer read_timer;
    Frame current;
    try {
      current = est.load(i);
    } catch (const Error& e) {
      // A real sequence has frames like this (a colour image the recorder dropped, a truncated
      // file): the frame is left out of the trajectory and named, the run carries on from the
      // last frame it could read.
      run.read_s += read_timer.seconds();
      run.skipped_frames.push_back(i);
      run.skip_reasons.push_back(e.what());
      OBM_LOG_WARN(kLog, e.what() << "; frame skipped");
      if (have_previous) ++skipped_since_previous;
      bar.update(i + 1, status());
      continue;
    }
    run.read_s += read_timer.seconds();
    if (have_previous) {
      // The guess spans every skipped frame: the constant velocity applied once per frame step.
      Eigen::Matrix4d guess = Eigen::Matrix4d::Identity();
      if (o.init == InitGuess::ConstantVelocity)
        for (std::size_t k = 0; k <= skipped_since_previous; ++k) guess = guess * velocity;
      Eigen::Matrix4d T_prev_cur = guess;
      std::string reason;
      Timer odo_timer;
      // Source = this frame, target = the previous one: the result maps this frame's points
      // into the previous frame, T_{i-1}_i.
      const bool ok = est.estimate(current, previous, guess, T_prev_cur, reason);
      run.odometry_s += odo_timer.seconds();
      if (!ok) {
        T_prev_cur = guess;
        run.failed_frames.push_back(i);
        run.failure_reasons.push_back(reason);
        OBM_LOG_INFO(kLog, frameName(i, seq.frame(i))
                               << ": " << reason << "; kept the " << toString(o.init)
                               << " guess");
      }
      velocity = T_prev_cur;
      if (skipped_since_previous > 0) {
        // Back to a per-frame step across the gap: the angle and the translation divided
        // evenly (the motion assumed uniform over the skipped frames).
        const double steps = static_cast<double>(skipped_since_previous + 1);
        const Isometry3d T = toIso(T_prev_cur);
        const Eigen::AngleAxisd aa(T.linear());
        Isometry3d step = Isometry3d::Identity();
        step.linear() = Eigen::AngleAxisd(aa.angle() / steps, aa.axis()).toRotationMatrix();
        step.translation() = T.translation() / steps;
        velocity = step.matrix();
      }
      T_world = T_world * toIso(T_prev_cur);
    }
    run.stamps.push_back(seq.frame(i).timestamp);
    run.frames.push_back(i);
    run.T_world_camera.push_back(T_world);
    previous = std::move(current);
    have_previous = true;
    skipped_since_previous = 0;
    bar.update(i + 1, status());
  }
  bar.finish(status());
  return run;
}

}  // namespace obm::o3d
