#include "obm/mrpt_bridge/conversions.hpp"

#include <mrpt/obs/CObservation3DRangeScan.h>
#include <mrpt/obs/CObservationVelodyneScan.h>

#include <Eigen/Eigenvalues>

#include "obm/core/errors.hpp"

namespace obm::mrpt_bridge {

namespace {
/// (yaw, pitch, roll) of R in MRPT's convention R = Rz(yaw)·Ry(pitch)·Rx(roll).
Eigen::Vector3d yawPitchRoll(const Eigen::Matrix3d& R) {
  const mrpt::poses::CPose3D p = toCPose3D(makeIsometry(R, Eigen::Vector3d::Zero()));
  return {p.yaw(), p.pitch(), p.roll()};
}
}  // namespace

PointCloud toPointCloud(const mrpt::maps::CPointsMap& map) {
  PointCloud c;
  const auto& xs = map.getPointsBufferRef_x();
  const auto& ys = map.getPointsBufferRef_y();
  const auto& zs = map.getPointsBufferRef_z();
  c.points.reserve(xs.size());
  for (std::size_t i = 0; i < xs.size(); ++i) c.points.emplace_back(xs[i], ys[i], zs[i]);
  c.frame_id = "robot";
  return c;
}

mrpt::maps::CSimplePointsMap toPointsMap(const PointCloud& cloud) {
  mrpt::maps::CSimplePointsMap m;
  m.reserve(cloud.size());
  for (const auto& p : cloud.points) m.insertPointFast(p.x(), p.y(), p.z());
  return m;
}

PointCloud observationToPointCloud(const mrpt::obs::CObservation& observation) {
  mrpt::maps::CSimplePointsMap m;
  // Every point: the default insertion drops points closer than 2 cm to the previous one.
  m.insertionOptions.minDistBetweenLaserPoints = 0.0f;
  m.insertionOptions.also_interpolate = false;
  bool inserted = false;
  if (const auto* velo = dynamic_cast<const mrpt::obs::CObservationVelodyneScan*>(&observation);
      velo != nullptr && velo->point_cloud.size() == 0) {
    // Raw packets as recorded: MRPT decodes them (its calibration, its range filters).
    mrpt::obs::CObservationVelodyneScan copy = *velo;
    copy.generatePointCloud();
    inserted = m.insertObservation(copy);
  } else if (const auto* rgbd = dynamic_cast<const mrpt::obs::CObservation3DRangeScan*>(&observation);
             rgbd != nullptr && rgbd->hasRangeImage) {
    // A depth image: MRPT's unprojection with the frame's intrinsics (loads an externally stored
    // image first), in the robot frame (sensorPose applied).
    mrpt::obs::CObservation3DRangeScan copy = *rgbd;
    mrpt::obs::T3DPointsProjectionParams pp;
    pp.takeIntoAccountSensorPoseOnRobot = true;
    copy.unprojectInto(m, pp);
    inserted = true;
  } else {
    inserted = m.insertObservation(observation);
  }
  if (!inserted || m.size() == 0)
    throw FormatError(observation.sensorLabel.empty() ? std::string("observation")
                                                      : observation.sensorLabel,
                      0,
                      std::string("a ") + observation.GetRuntimeClass()->className +
                          " that yields no point (MRPT cannot insert it into a point map, or it "
                          "is empty)");
  return toPointCloud(m);
}

mrpt::poses::CPose3D toCPose3D(const Isometry3d& T) {
  mrpt::math::CMatrixDouble44 M;
  for (int r = 0; r < 4; ++r)
    for (int c = 0; c < 4; ++c) M(r, c) = T.matrix()(r, c);
  return mrpt::poses::CPose3D(M);
}

Isometry3d fromCPose3D(const mrpt::poses::CPose3D& pose) {
  const auto M = pose.getHomogeneousMatrixVal<mrpt::math::CMatrixDouble44>();
  Eigen::Matrix3d R;
  Eigen::Vector3d t;
  for (int r = 0; r < 3; ++r) {
    for (int c = 0; c < 3; ++c) R(r, c) = M(r, c);
    t[r] = M(r, 3);
  }
  return makeIsometry(R, t);
}

mrpt::poses::CPose3DPDFGaussian toPose3DPDFGaussian(const Isometry3d& T, const Matrix6d& information,
                                                     double unconstrained_variance) {
  // Σ_δ = Ω⁻¹ on the constrained directions, `unconstrained_variance` on the others.
  const Matrix6d Omega = 0.5 * (information + information.transpose());
  Eigen::SelfAdjointEigenSolver<Matrix6d> es(Omega);
  const auto& ev = es.eigenvalues();
  const double top = std::max(ev.maxCoeff(), 0.0);
  Eigen::Matrix<double, 6, 1> var;
  for (int i = 0; i < 6; ++i)
    var[i] = (top > 0 && ev[i] > 1e-9 * top) ? 1.0 / ev[i] : unconstrained_variance;
  const Matrix6d cov_delta = es.eigenvectors() * var.asDiagonal() * es.eigenvectors().transpose();

  // J = ∂(x, y, z, yaw, pitch, roll)/∂[ρ; θ] at T·Exp(δ), δ = 0: the translation moves by R·ρ;
  // the angles by central differences of (yaw, pitch, roll)(R·Exp(θ)).
  const Eigen::Matrix3d R = T.linear();
  Matrix6d J = Matrix6d::Zero();
  J.block<3, 3>(0, 0) = R;
  const double h = 1e-6;
  for (int k = 0; k < 3; ++k) {
    const Eigen::Vector3d e = Eigen::Vector3d::Unit(k) * h;
    const Eigen::Vector3d a = yawPitchRoll(R * expSO3(e)), b = yawPitchRoll(R * expSO3(-e));
    for (int i = 0; i < 3; ++i) J(3 + i, 3 + k) = wrapAngle(a[i] - b[i]) / (2 * h);
  }
  const Matrix6d cov = J * cov_delta * J.transpose();
  mrpt::math::CMatrixDouble66 C;
  for (int r = 0; r < 6; ++r)
    for (int c = 0; c < 6; ++c) C(r, c) = 0.5 * (cov(r, c) + cov(c, r));
  return mrpt::poses::CPose3DPDFGaussian(toCPose3D(T), C);
}

}  // namespace obm::mrpt_bridge
