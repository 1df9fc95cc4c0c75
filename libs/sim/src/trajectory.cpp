#include "obm/sim/trajectory.hpp"

#include <algorithm>
#include <array>
#include <cmath>

#include "obm/core/errors.hpp"
#include "obm/core/se3.hpp"
#include "obm/io/kitti.hpp"
#include "obm/io/trajectory.hpp"

namespace obm::sim {

void Trajectory::push_back(double t, const Eigen::Isometry3d& T_world_sensor) {
  stamps.push_back(t);
  poses.push_back(T_world_sensor);
}

Eigen::Isometry3d Trajectory::interpolate(double t) const {
  OBM_ASSERT(!poses.empty(), "interpolating an empty trajectory '" + source + "'");
  if (t <= stamps.front()) return poses.front();
  if (t >= stamps.back()) return poses.back();
  const auto it = std::upper_bound(stamps.begin(), stamps.end(), t);
  const std::size_t i1 = static_cast<std::size_t>(it - stamps.begin()), i0 = i1 - 1;
  const double a = (t - stamps[i0]) / (stamps[i1] - stamps[i0]);
  const Eigen::Quaterniond q0(poses[i0].linear()), q1(poses[i1].linear());
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = q0.slerp(a, q1).normalized().toRotationMatrix();
  T.translation() = (1.0 - a) * poses[i0].translation() + a * poses[i1].translation();
  return T;
}

double Trajectory::length() const {
  double s = 0.0;
  for (std::size_t i = 1; i < poses.size(); ++i)
    s += (poses[i].translation() - poses[i - 1].translation()).norm();
  return s;
}

double Trajectory::extent() const {
  double e = 0.0;
  for (const auto& T : poses)
    e = std::max(e, (T.translation() - poses.front().translation()).norm());
  return e;
}

void Trajectory::validate() const {
  if (stamps.size() != poses.size())
    throw FormatError(source, 0,
                      std::to_string(stamps.size()) + " time stamps for " +
                          std::to_string(poses.size()) + " poses");
  for (std::size_t i = 0; i < poses.size(); ++i) {
    if (i > 0 && !(stamps[i] > stamps[i - 1]))
      throw FormatError(source, 0,
                        "time stamps must increase: pose " + std::to_string(i) + " has t = " +
                            std::to_string(stamps[i]) + " after " + std::to_string(stamps[i - 1]));
    const Eigen::Matrix3d& R = poses[i].linear();
    if (!R.allFinite() || !poses[i].translation().allFinite() ||
        (R.transpose() * R - Eigen::Matrix3d::Identity()).norm() > 1e-3)
      throw FormatError(source, 0, "pose " + std::to_string(i) + " is not a rigid transform");
  }
}

Trajectory Trajectory::head(std::size_t n) const {
  if (n == 0 || n >= size()) return *this;
  Trajectory out;
  out.source = source;
  out.stamps.assign(stamps.begin(), stamps.begin() + static_cast<std::ptrdiff_t>(n));
  out.poses.assign(poses.begin(), poses.begin() + static_cast<std::ptrdiff_t>(n));
  return out;
}

Trajectory Trajectory::resampled(double rate_hz) const {
  OBM_ASSERT(rate_hz > 0.0, "resampling rate must be positive");
  Trajectory out;
  out.source = source;
  if (empty()) return out;
  const double dt = 1.0 / rate_hz;
  const double t0 = stamps.front(), t1 = stamps.back();
  const auto n = static_cast<std::size_t>(std::floor((t1 - t0) / dt + 1e-9)) + 1;
  for (std::size_t k = 0; k < n; ++k) {
    const double t = t0 + static_cast<double>(k) * dt;
    out.push_back(t, interpolate(t));
  }
  return out;
}

Trajectory Trajectory::transformed(const Eigen::Isometry3d& T_newworld_world,
                                   const Eigen::Isometry3d& T_sensor_newsensor) const {
  Trajectory out = *this;
  for (auto& T : out.poses) T = T_newworld_world * T * T_sensor_newsensor;
  return out;
}

KittiCalibration KittiCalibration::kitti00() {
  KittiCalibration c;
  // KITTI odometry calib.txt of sequences 00–02 (drive 2011_10_03).
  const std::array<double, 12> tr = {4.276802385584e-04,  -9.999672484946e-01, -8.084491683471e-03,
                                     -1.198459927713e-02, -7.210626507497e-03, 8.081198471645e-03,
                                     -9.999413164504e-01, -5.403984729748e-02, 9.999738645903e-01,
                                     4.859485810390e-04,  -7.206933692422e-03, -2.921968648686e-01};
  c.T_cam0_velo = fromRowMajor3x4(tr);
  // Orthonormal to 1e-16 (the file's is to ~1e-7), so camera ↔ LiDAR conversions are exact.
  c.T_cam0_velo.linear() = orthonormalize(c.T_cam0_velo.linear());
  // Rows of P0..P3 (rectified projections of the grey and colour stereo pairs).
  const double P[4][12] = {
      {718.856, 0, 607.1928, 0, 0, 718.856, 185.2157, 0, 0, 0, 1, 0},
      {718.856, 0, 607.1928, -386.1448, 0, 718.856, 185.2157, 0, 0, 0, 1, 0},
      {718.856, 0, 607.1928, 45.38225, 0, 718.856, 185.2157, -0.1130887, 0, 0, 1, 0.003779761},
      {718.856, 0, 607.1928, -337.2877, 0, 718.856, 185.2157, 2.369057, 0, 0, 1, 0.004915215}};
  for (int i = 0; i < 4; ++i)
    for (int k = 0; k < 12; ++k) c.P[i][k] = P[i][k];
  return c;
}

Trajectory loadKittiTrajectory(const std::string& poses_file, const std::string& times_file,
                               const Eigen::Isometry3d& T_cam0_velo, std::size_t max_poses) {
  std::vector<Eigen::Isometry3d> cam = io::readKittiPoses(poses_file);
  if (cam.empty()) throw FormatError(poses_file, 0, "no poses in the file");
  if (max_poses > 0 && cam.size() > max_poses) cam.resize(max_poses);
  std::vector<double> times;
  if (!times_file.empty()) {
    times = io::readKittiTimes(times_file);
    if (times.size() < cam.size())
      throw FormatError(times_file, 0,
                        std::to_string(times.size()) + " time stamps for " +
                            std::to_string(cam.size()) + " poses of '" + poses_file + "'");
    times.resize(cam.size());
  } else {
    for (std::size_t i = 0; i < cam.size(); ++i) times.push_back(0.1 * static_cast<double>(i));
  }
  Trajectory out;
  out.source = poses_file;
  const auto velo = io::cameraToLidarPoses(cam, T_cam0_velo);
  for (std::size_t i = 0; i < velo.size(); ++i) out.push_back(times[i], velo[i]);
  out.validate();
  return out;
}

Trajectory loadTumTrajectory(const std::string& file, std::size_t max_poses) {
  const io::Trajectory tum = io::readTumTrajectory(file);
  if (tum.empty()) throw FormatError(file, 0, "no poses in the file");
  Trajectory out;
  out.source = file;
  for (const auto& sp : tum) {
    if (max_poses > 0 && out.size() >= max_poses) break;
    // Motion-capture files occasionally repeat a stamp; keep the first pose of each.
    if (!out.stamps.empty() && !(sp.t > out.stamps.back())) continue;
    out.push_back(sp.t, sp.T);
  }
  out.validate();
  return out;
}

}  // namespace obm::sim
