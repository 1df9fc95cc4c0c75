#pragma once
/// \file odometry.hpp
/// obm-o3d-odometry's work: Open3D's classical frame-to-frame RGB-D odometry over a sequence read
/// by libs/io (obm::io::RgbdSequence). Open3D's types stay in odometry.cpp: this header names
/// none of them, so main.cpp builds without Open3D's headers.
#include <atomic>
#include <cstddef>
#include <string>
#include <vector>

#include "obm/core/log.hpp"
#include "obm/core/se3.hpp"
#include "obm/io/rgbd.hpp"

namespace obm::o3d {

/// The pairwise estimator between consecutive frames.
enum class Method {
  Hybrid,     ///< ComputeRGBDOdometry, RGBDOdometryJacobianFromHybridTerm (photometric + depth)
  Color,      ///< ComputeRGBDOdometry, RGBDOdometryJacobianFromColorTerm (photometric only)
  ColoredIcp  ///< RegistrationColoredICP, coarse to fine on voxel-down-sampled coloured clouds
};

/// "hybrid", "color", "colored_icp".
std::string toString(Method method);

/// The inverse of toString(); ConfigError naming `what` (the option) for another text.
Method parseMethod(const std::string& text, const std::string& what);

/// The starting guess of each frame-to-frame estimate (also what a failed frame keeps).
enum class InitGuess {
  ConstantVelocity,  ///< the previous frame's relative motion
  Identity           ///< no motion (Open3D's default odo_init)
};

/// "velocity", "identity".
std::string toString(InitGuess init);

/// The inverse of toString(); ConfigError naming `what` for another text.
InitGuess parseInitGuess(const std::string& text, const std::string& what);

struct OdometryOptions {
  Method method = Method::Hybrid;
  InitGuess init = InitGuess::ConstantVelocity;
  double depth_min = 0.3;  ///< [m] nearer depth is ignored (config/map_indoor.yaml input.depth_min)
  double depth_max = 4.0;  ///< [m] farther depth is ignored (config/map_indoor.yaml input.depth_max)
  /// Coloured ICP, coarse to fine: voxel size of each level [m] (also its correspondence
  /// distance; normals from neighbours within twice the voxel) and its iteration cap.
  std::vector<double> icp_voxels{0.04, 0.02, 0.01};
  std::vector<int> icp_iterations{50, 30, 14};
  /// Coloured ICP: weight of the geometric (point-to-plane) term against the photometric one,
  /// in [0, 1]; Open3D's default.
  double icp_lambda_geometric = 0.968;
  std::size_t max_frames = 0;  ///< 0 = every frame of the sequence
  bool progress = true;        ///< progress bar on stderr
  const std::atomic<bool>* cancel = nullptr;  ///< polled once per frame
};

/// What runOdometry() produced.
struct OdometryRun {
  std::vector<double> stamps;                ///< [s] depth time stamp of every processed frame
  std::vector<std::size_t> frames;           ///< its index in the sequence (skipped ones absent)
  std::vector<Isometry3d> T_world_camera;    ///< optical frame; the first frame is the identity
  std::vector<std::size_t> failed_frames;    ///< frames whose estimate failed (the guess was kept)
  std::vector<std::string> failure_reasons;  ///< one per failed frame
  /// Frames that could not be read (no colour image associated, a missing or unreadable file):
  /// left out of the trajectory, the next frame registered against the last one read.
  std::vector<std::size_t> skipped_frames;
  std::vector<std::string> skip_reasons;  ///< one per skipped frame (names the frame and file)
  double read_s = 0.0;                       ///< [s] reading the images and preparing them
  double odometry_s = 0.0;                   ///< [s] in Open3D's estimators
  bool interrupted = false;                  ///< stopped by `cancel`
};

/// Frame-to-frame odometry of `seq` (its intrinsics, depth scale and time stamps); each frame's
/// depth and colour images are read with Open3D's own reader (PNG, JPEG). The relative motion
/// of frame i is estimated against frame i − 1 from the `init` guess and chained:
/// T_world_i = T_world_{i−1} · T_{i−1}_i. A frame whose images cannot be used (no colour image
/// associated with it, a missing or unreadable file, the wrong type or size) is skipped and
/// listed in OdometryRun::skipped_frames with the error naming the frame and the file; the next
/// frame is registered against the last one read, from the velocity guess spanning the gap.
OdometryRun runOdometry(const io::RgbdSequence& seq, const OdometryOptions& options);

/// Open3D's global verbosity for the project's log level: debug → Debug, info → Warning, else
/// Error (Open3D's per-frame warnings are counted as failures instead).
void setOpen3dVerbosity(LogLevel level);

}  // namespace obm::o3d
