#pragma once
/// \file edge_information.hpp
/// Information matrices (g2o's (t, vec q) parametrisation) of the pose-graph edges the front-end
/// adds: odometry edges from an accepted tracking match, bridge edges (constant-velocity motion,
/// a restart of the local map) and loop edges from a verified loop closure. Private to
/// libs/frontend.
#include "obm/core/se3.hpp"
#include "obm/frontend/params.hpp"
#include "obm/registration/match_result.hpp"

namespace obm::frontend {

/// Ω_edge = (Ω⁻¹ + Σ_floor)⁻¹ = Ω (I + Σ_floor Ω)⁻¹ (valid for a singular Ω), symmetrised, with
/// eigenvalues clamped to >= 1 (σ <= 1 m or 1 rad along any direction) so the graph stays
/// solvable, then converted to g2o's (t, vec q) parametrisation. `omega_theta` is a match's
/// information (MatchResult::information), multiplied by `scale` first.
Matrix6d edgeInformation(const Matrix6d& omega_theta, double scale, double sigma_t,
                         double sigma_r);

/// Information of a constant-velocity bridge edge: diag(1/σ_t², 1/σ_r²) (g2o parametrisation).
Matrix6d bridgeInformation(double sigma_t, double sigma_r);

/// The edge from the previous keyframe to a new one: a bridge edge (TrackingParams::bridge_sigma_*)
/// when the keyframe restarts the local map or has no match, else the match's information with
/// the odometry floor (TrackingParams::information_scale, floor_sigma_*).
Matrix6d odometryEdgeInformation(const TrackingParams& params,
                                 const registration::MatchResult* match, bool bridged);

/// A verified loop closure's edge: the match's information with the loop floor
/// (LoopClosureParams::information_scale, floor_sigma_*).
Matrix6d loopEdgeInformation(const LoopClosureParams& params,
                             const registration::MatchResult& match);

}  // namespace obm::frontend
