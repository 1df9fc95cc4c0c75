#pragma once
/// \file conversions.hpp
/// Between MRPT's types and obmslam's: point maps and observations to PointCloud, poses, and a
/// match's information matrix to the covariance of an mrpt::poses::CPose3DPDFGaussian.
///
/// Frames: MRPT's observations carry their `sensorPose` on the robot; the clouds made from them
/// here are in the **robot** frame (as CPointsMap::insertObservation builds them), so that two
/// observations register robot to robot.
#include <mrpt/maps/CPointsMap.h>
#include <mrpt/maps/CSimplePointsMap.h>
#include <mrpt/obs/CObservation.h>
#include <mrpt/poses/CPose3D.h>
#include <mrpt/poses/CPose3DPDFGaussian.h>

#include "obm/core/point_cloud.hpp"
#include "obm/core/se3.hpp"

namespace obm::mrpt_bridge {

/// The points of an MRPT point map (any CPointsMap: simple, colored, with intensity). Colours and
/// intensities are not copied.
PointCloud toPointCloud(const mrpt::maps::CPointsMap& map);
/// A simple point map of `cloud`'s points.
mrpt::maps::CSimplePointsMap toPointsMap(const PointCloud& cloud);

/// The points of an observation in the robot frame, made by MRPT itself: CPointsMap's
/// insertObservation (every point kept: no minimum distance between points), after
/// CObservationVelodyneScan::generatePointCloud for raw Velodyne packets and after loading the
/// external range image of a CObservation3DRangeScan. Works for every observation MRPT can insert
/// into a point map (CObservationPointCloud, CObservation3DRangeScan, CObservationVelodyneScan,
/// CObservation2DRangeScan, …). Throws obm::FormatError naming the observation's class and sensor
/// label when it yields no point.
PointCloud observationToPointCloud(const mrpt::obs::CObservation& observation);

mrpt::poses::CPose3D toCPose3D(const Isometry3d& T);
Isometry3d fromCPose3D(const mrpt::poses::CPose3D& pose);

/// The Gaussian pose PDF of a registration: mean T, covariance in MRPT's parametrisation
/// (x, y, z, yaw, pitch, roll) from the information Ω over the right (source-frame) twist
/// δ = [ρ; θ] of match_result.hpp: Σ_mrpt = J·Ω⁻¹·Jᵀ with J = ∂(x, y, z, yaw, pitch, roll)/∂δ at
/// T (the translation block is R, the angular block is evaluated by central differences).
/// Directions Ω leaves unconstrained (eigenvalues below 1e-9 of the largest, or an all-zero Ω)
/// get the variance `unconstrained_variance` [m², rad²] instead of infinity.
mrpt::poses::CPose3DPDFGaussian toPose3DPDFGaussian(const Isometry3d& T, const Matrix6d& information,
                                                     double unconstrained_variance = 1e4);

}  // namespace obm::mrpt_bridge
