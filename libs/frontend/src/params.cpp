#include "obm/frontend/params.hpp"

#include <algorithm>
#include <cmath>
#include <string>
#include <vector>

#include "obm/config/config_node.hpp"
#include "obm/core/errors.hpp"

namespace obm::frontend {

namespace {

/// Throws ConfigError "<where>: <what>" when `ok` is false. `where` is the YAML key path when the
/// value came from a file, else the field name.
void require(bool ok, const std::string& where, const std::string& what) {
  if (!ok) throw ConfigError(where + ": " + what);
}

bool finite(double v) {
  return std::isfinite(v);
}

/// Re-throws a validation error with the YAML location of the section in front.
template <typename F>
void validateAt(const ConfigNode& node, F&& validate) {
  try {
    validate();
  } catch (const ConfigError& e) {
    throw ConfigError(node.where() + ": " + e.what());
  }
}

}  // namespace

// --- preprocess ------------------------------------------------------------------------------

void PreprocessParams::validate() const {
  require(finite(min_range) && min_range >= 0.0, "min_range", "must be >= 0 [m]");
  require(finite(max_range), "max_range", "must be finite (<= 0 = no upper bound)");
  require(max_range <= 0.0 || max_range > min_range, "max_range", "must exceed min_range");
  require(finite(voxel) && voxel >= 0.0, "voxel", "must be >= 0 [m] (0 = off)");
}

PreprocessParams PreprocessParams::load(const ConfigNode& node) {
  node.checkKeys({"min_range", "max_range", "voxel", "max_points", "seed"});
  PreprocessParams p;
  node.get("min_range", p.min_range);
  node.get("max_range", p.max_range);
  node.get("voxel", p.voxel);
  node.get("max_points", p.max_points);
  node.get("seed", p.seed);
  validateAt(node, [&] { p.validate(); });
  return p;
}

// --- keyframes -------------------------------------------------------------------------------

void KeyframeParams::validate() const {
  require(finite(distance) && distance > 0.0, "distance", "must be > 0 [m]");
  require(finite(rotation) && rotation > 0.0, "rotation_deg", "must be > 0 [deg]");
  require(finite(revisit_radius) && revisit_radius >= 0.0, "revisit_radius",
          "must be >= 0 [m] (0 = keep every keyframe cloud)");
  require(finite(overlap_drop) && overlap_drop >= 0.0 && overlap_drop < 1.0, "overlap_drop",
          "must be in [0, 1) (a fraction of the recent inlier ratio; 0 = off)");
}

KeyframeParams KeyframeParams::load(const ConfigNode& node) {
  node.checkKeys({"distance", "rotation_deg", "max_frames", "revisit_radius", "overlap_drop",
                  "overlap_min_frames"});
  KeyframeParams p;
  node.get("distance", p.distance);
  node.getDegAsRad("rotation_deg", p.rotation);
  node.get("max_frames", p.max_frames);
  node.get("revisit_radius", p.revisit_radius);
  node.get("overlap_drop", p.overlap_drop);
  node.get("overlap_min_frames", p.overlap_min_frames);
  validateAt(node, [&] { p.validate(); });
  return p;
}

// --- local map -------------------------------------------------------------------------------

void LocalMapParams::validate() const {
  require(keyframes >= 1, "keyframes", "must be >= 1");
  require(finite(voxel) && voxel >= 0.0, "voxel", "must be >= 0 [m] (0 = off)");
  require(finite(radius) && radius > 0.0, "radius", "must be > 0 [m]");
  require(rebuild_every >= 1, "rebuild_every", "must be >= 1");
}

LocalMapParams LocalMapParams::load(const ConfigNode& node) {
  node.checkKeys({"keyframes", "voxel", "radius", "async", "rebuild_every", "keyframe_normals"});
  LocalMapParams p;
  node.get("keyframes", p.keyframes);
  node.get("voxel", p.voxel);
  node.get("radius", p.radius);
  node.get("async", p.async);
  node.get("rebuild_every", p.rebuild_every);
  node.get("keyframe_normals", p.keyframe_normals);
  validateAt(node, [&] { p.validate(); });
  return p;
}

// --- tracking --------------------------------------------------------------------------------

void TrackingParams::validate() const {
  require(min_quality >= 0.0 && min_quality <= 1.0, "min_quality", "must be in [0, 1]");
  require(finite(max_correction) && max_correction > 0.0, "max_correction", "must be > 0 [m]");
  require(finite(max_correction_rotation) && max_correction_rotation > 0.0,
          "max_correction_rotation_deg", "must be > 0 [deg]");
  require(finite(recovery_gate) && recovery_gate >= 0.0, "recovery_gate",
          "must be >= 0 [m] (0 = no recovery)");
  require(finite(recovery_max_correction) && recovery_max_correction > 0.0,
          "recovery_max_correction", "must be > 0 [m]");
  require(recovery_min_quality >= 0.0 && recovery_min_quality <= 1.0, "recovery_min_quality",
          "must be in [0, 1]");
  require(relative_inlier_ratio >= 0.0 && relative_inlier_ratio <= 1.0, "relative_inlier_ratio",
          "must be in [0, 1]");
  require(recovery_relative_inlier_ratio >= 0.0 && recovery_relative_inlier_ratio <= 1.0,
          "recovery_relative_inlier_ratio", "must be in [0, 1]");
  require(finite(recovery_rotation_step) && recovery_rotation_step > 0.0,
          "recovery_rotation_step_deg", "must be > 0 [deg]");
  require(recovery_rotation_hypotheses >= 0, "recovery_rotation_hypotheses", "must be >= 0");
  require(finite(guess_agreement_translation) && guess_agreement_translation >= 0.0,
          "guess_agreement_translation", "must be >= 0 [m] (0 = off)");
  require(finite(guess_agreement_rotation) && guess_agreement_rotation > 0.0,
          "guess_agreement_rotation_deg", "must be > 0 [deg]");
  require(guess_agreement_relative_inlier_ratio >= 0.0 &&
              guess_agreement_relative_inlier_ratio <= 1.0,
          "guess_agreement_relative_inlier_ratio", "must be in [0, 1]");
  require(finite(recovery_agreement_translation) && recovery_agreement_translation >= 0.0,
          "recovery_agreement_translation", "must be >= 0 [m] (0 = no second opinion)");
  require(finite(recovery_agreement_rotation) && recovery_agreement_rotation > 0.0,
          "recovery_agreement_rotation_deg", "must be > 0 [deg]");
  require(recovery_confirmed_relative_inlier_ratio >= 0.0 &&
              recovery_confirmed_relative_inlier_ratio <= 1.0,
          "recovery_confirmed_relative_inlier_ratio", "must be in [0, 1]");
  require(!recovery_confirm_jumps || recovery_agreement_translation > 0.0,
          "recovery_confirm_jumps",
          "needs recovery_agreement_translation > 0 (the agreement that confirms a jump)");
  require(finite(recovery_gap_min_steps) && recovery_gap_min_steps >= 0.0, "recovery_gap_min_steps",
          "must be >= 0 (0 = never)");
  require(finite(recovery_gap_turn_step) && recovery_gap_turn_step > 0.0,
          "recovery_gap_turn_step_deg", "must be > 0 [deg]");
  require(finite(recovery_gap_speed_min) && recovery_gap_speed_min > 0.0, "recovery_gap_speed_min",
          "must be > 0");
  require(finite(recovery_gap_speed_max) && recovery_gap_speed_max >= recovery_gap_speed_min,
          "recovery_gap_speed_max", "must be >= recovery_gap_speed_min");
  require(std::all_of(recovery_gap_corner_turns.begin(), recovery_gap_corner_turns.end(),
                      [](double a) { return std::isfinite(a) && a > 0.0; }),
          "recovery_gap_corner_turns_deg", "must be angles > 0 [deg] (or an empty list)");
  require(finite(recovery_gap_start_spacing) && recovery_gap_start_spacing > 0.0,
          "recovery_gap_start_spacing", "must be > 0 [m]");
  require(recovery_gap_relative_inlier_ratio >= 0.0 && recovery_gap_relative_inlier_ratio <= 1.0,
          "recovery_gap_relative_inlier_ratio", "must be in [0, 1]");
  require(finite(recovery_gap_map_radius) && recovery_gap_map_radius >= 0.0,
          "recovery_gap_map_radius", "must be >= 0 [m] (0 = the local map only)");
  require(recovery_jump_max_steps >= 0, "recovery_jump_max_steps", "must be >= 0 (0 = never)");
  require(recovery_gap_min_support >= 1, "recovery_gap_min_support", "must be >= 1");
  require(recovery_gap_rival_ratio > 0.0 && recovery_gap_rival_ratio <= 1.0,
          "recovery_gap_rival_ratio", "must be in (0, 1]");
  require(finite(recovery_gap_agreement_translation) && recovery_gap_agreement_translation > 0.0,
          "recovery_gap_agreement_translation", "must be > 0 [m]");
  require(finite(recovery_gap_agreement_rotation) && recovery_gap_agreement_rotation > 0.0,
          "recovery_gap_agreement_rotation_deg", "must be > 0 [deg]");
  require(recovery_large_turn_relative_inlier_ratio >= 0.0 &&
              recovery_large_turn_relative_inlier_ratio <= 1.0,
          "recovery_large_turn_relative_inlier_ratio", "must be in [0, 1] (0 = never)");
  require(max_bridge_frames >= 1, "max_bridge_frames", "must be >= 1");
  require(finite(information_scale) && information_scale > 0.0, "information_scale", "must be > 0");
  require(finite(floor_sigma_translation) && floor_sigma_translation >= 0.0,
          "floor_sigma_translation", "must be >= 0 [m]");
  require(finite(floor_sigma_rotation) && floor_sigma_rotation >= 0.0, "floor_sigma_rotation_deg",
          "must be >= 0 [deg]");
  require(finite(bridge_sigma_translation) && bridge_sigma_translation > 0.0,
          "bridge_sigma_translation", "must be > 0 [m]");
  require(finite(bridge_sigma_rotation) && bridge_sigma_rotation > 0.0, "bridge_sigma_rotation_deg",
          "must be > 0 [deg]");
  require(finite(start_search_range) && start_search_range >= 0.0, "start_search_range",
          "must be >= 0 [m] (0 = no start search)");
  require(finite(start_search_step) && start_search_step > 0.0, "start_search_step",
          "must be > 0 [m]");
  require(start_search_axis.allFinite() && std::abs(start_search_axis.norm() - 1.0) < 1e-6,
          "start_search_axis", "must be a unit vector [x, y, z] in the sensor frame");
  icp.validate();
  confidence.validate();
}

TrackingParams TrackingParams::load(const ConfigNode& node) {
  node.checkKeys({"icp",
                  "confidence",
                  "min_quality",
                  "max_correction",
                  "max_correction_rotation_deg",
                  "relative_inlier_ratio",
                  "recovery_gate",
                  "recovery_max_correction",
                  "recovery_min_quality",
                  "recovery_relative_inlier_ratio",
                  "recovery_rotation_step_deg",
                  "recovery_rotation_hypotheses",
                  "recovery_agreement_translation",
                  "recovery_agreement_rotation_deg",
                  "guess_agreement_translation",
                  "guess_agreement_rotation_deg",
                  "guess_agreement_relative_inlier_ratio",
                  "recovery_confirm_jumps",
                  "recovery_repeated_jump_is_velocity",
                  "recovery_confirmed_relative_inlier_ratio",
                  "recovery_gap_rotation",
                  "recovery_large_turn_relative_inlier_ratio",
                  "recovery_gap_min_steps",
                  "recovery_gap_turn_step_deg",
                  "recovery_gap_speed_min",
                  "recovery_gap_speed_max",
                  "recovery_gap_start_spacing",
                  "recovery_gap_corner_turns_deg",
                  "recovery_gap_relative_inlier_ratio",
                  "recovery_gap_min_support",
                  "recovery_gap_rival_ratio",
                  "recovery_gap_agreement_translation",
                  "recovery_gap_agreement_rotation_deg", "recovery_gap_map_radius",
                  "recovery_jump_max_steps",
                  "max_bridge_frames",
                  "information_scale",
                  "floor_sigma_translation",
                  "floor_sigma_rotation_deg",
                  "bridge_sigma_translation",
                  "bridge_sigma_rotation_deg",
                  "use_timestamps",
                  "start_search_range",
                  "start_search_step",
                  "start_search_axis",
                  "start_search_matcher"});
  TrackingParams p;
  p.icp = registration::IcpParams::load(node.child("icp"));
  p.confidence = registration::ConfidenceParams::load(node.child("confidence"));
  node.get("min_quality", p.min_quality);
  node.get("max_correction", p.max_correction);
  node.getDegAsRad("max_correction_rotation_deg", p.max_correction_rotation);
  node.get("recovery_gate", p.recovery_gate);
  node.get("recovery_max_correction", p.recovery_max_correction);
  node.get("recovery_min_quality", p.recovery_min_quality);
  node.get("relative_inlier_ratio", p.relative_inlier_ratio);
  node.get("recovery_relative_inlier_ratio", p.recovery_relative_inlier_ratio);
  node.getDegAsRad("recovery_rotation_step_deg", p.recovery_rotation_step);
  node.get("recovery_rotation_hypotheses", p.recovery_rotation_hypotheses);
  node.get("guess_agreement_translation", p.guess_agreement_translation);
  node.getDegAsRad("guess_agreement_rotation_deg", p.guess_agreement_rotation);
  node.get("guess_agreement_relative_inlier_ratio", p.guess_agreement_relative_inlier_ratio);
  node.get("recovery_agreement_translation", p.recovery_agreement_translation);
  node.getDegAsRad("recovery_agreement_rotation_deg", p.recovery_agreement_rotation);
  node.get("recovery_confirm_jumps", p.recovery_confirm_jumps);
  node.get("recovery_repeated_jump_is_velocity", p.recovery_repeated_jump_is_velocity);
  node.get("recovery_confirmed_relative_inlier_ratio", p.recovery_confirmed_relative_inlier_ratio);
  node.get("recovery_gap_rotation", p.recovery_gap_rotation);
  node.get("recovery_large_turn_relative_inlier_ratio",
           p.recovery_large_turn_relative_inlier_ratio);
  node.get("recovery_gap_min_steps", p.recovery_gap_min_steps);
  node.getDegAsRad("recovery_gap_turn_step_deg", p.recovery_gap_turn_step);
  node.get("recovery_gap_speed_min", p.recovery_gap_speed_min);
  node.get("recovery_gap_speed_max", p.recovery_gap_speed_max);
  node.get("recovery_gap_start_spacing", p.recovery_gap_start_spacing);
  if (node.has("recovery_gap_corner_turns_deg")) {
    node.get("recovery_gap_corner_turns_deg", p.recovery_gap_corner_turns);
    for (double& a : p.recovery_gap_corner_turns) a *= kDegToRad;
  }
  node.get("recovery_gap_relative_inlier_ratio", p.recovery_gap_relative_inlier_ratio);
  node.get("recovery_gap_min_support", p.recovery_gap_min_support);
  node.get("recovery_gap_rival_ratio", p.recovery_gap_rival_ratio);
  node.get("recovery_gap_agreement_translation", p.recovery_gap_agreement_translation);
  node.getDegAsRad("recovery_gap_agreement_rotation_deg", p.recovery_gap_agreement_rotation);
  node.get("recovery_gap_map_radius", p.recovery_gap_map_radius);
  node.get("recovery_jump_max_steps", p.recovery_jump_max_steps);
  node.get("max_bridge_frames", p.max_bridge_frames);
  node.get("information_scale", p.information_scale);
  node.get("floor_sigma_translation", p.floor_sigma_translation);
  node.getDegAsRad("floor_sigma_rotation_deg", p.floor_sigma_rotation);
  node.get("bridge_sigma_translation", p.bridge_sigma_translation);
  node.getDegAsRad("bridge_sigma_rotation_deg", p.bridge_sigma_rotation);
  node.get("use_timestamps", p.use_timestamps);
  node.get("start_search_range", p.start_search_range);
  node.get("start_search_step", p.start_search_step);
  node.get("start_search_matcher", p.start_search_matcher);
  if (node.has("start_search_axis")) {
    std::vector<double> a;
    node.get("start_search_axis", a);
    if (a.size() != 3)
      throw ConfigError(node.where("start_search_axis") + ": needs 3 numbers [x, y, z], got " +
                        std::to_string(a.size()));
    p.start_search_axis = Eigen::Vector3d(a[0], a[1], a[2]);
  }
  validateAt(node, [&] {
    try {
      p.validate();
    } catch (const ContractError& e) {  // IcpParams / ConfidenceParams report ContractError
      throw ConfigError(e.what());
    }
  });
  return p;
}

// --- descriptor ------------------------------------------------------------------------------

void DescriptorParams::validate() const {
  require(rings >= 1, "rings", "must be >= 1");
  require(sectors >= 4, "sectors", "must be >= 4");
  require(finite(max_range) && max_range > 0.0, "max_range", "must be > 0 [m]");
  require(finite(height_offset), "height_offset", "must be finite [m]");
}

DescriptorParams DescriptorParams::load(const ConfigNode& node) {
  node.checkKeys({"rings", "sectors", "max_range", "height_offset"});
  DescriptorParams p;
  node.get("rings", p.rings);
  node.get("sectors", p.sectors);
  node.get("max_range", p.max_range);
  node.get("height_offset", p.height_offset);
  validateAt(node, [&] { p.validate(); });
  return p;
}

// --- loop closure ----------------------------------------------------------------------------

void RelocalisationParams::validate() const {
  require(max_descriptor_distance >= 0.0 && max_descriptor_distance <= 1.0,
          "max_descriptor_distance", "must be in [0, 1]");
  require(max_candidates >= 1, "max_candidates", "must be >= 1");
  require(min_quality >= 0.0 && min_quality <= 1.0, "min_quality", "must be in [0, 1]");
  require(min_inlier_ratio >= 0.0 && min_inlier_ratio <= 1.0, "min_inlier_ratio",
          "must be in [0, 1]");
  require(confirmations >= 1, "confirmations", "must be >= 1");
  require(finite(agreement_translation) && agreement_translation > 0.0, "agreement_translation",
          "must be > 0 [m]");
  require(finite(agreement_rotation) && agreement_rotation > 0.0, "agreement_rotation_deg",
          "must be > 0 [deg]");
}

void LoopClosureParams::validate() const {
  require(finite(min_travel) && min_travel > 0.0, "min_travel", "must be > 0 [m]");
  require(finite(search_radius) && search_radius > 0.0, "search_radius", "must be > 0 [m]");
  require(finite(search_radius_per_m) && search_radius_per_m >= 0.0, "search_radius_per_m",
          "must be >= 0");
  require(finite(max_search_radius) && max_search_radius >= search_radius, "max_search_radius",
          "must be >= search_radius [m]");
  require(finite(max_view_angle) && max_view_angle >= 0.0, "max_view_angle_deg",
          "must be >= 0 [deg] (0 = no bound)");
  require(check_every >= 1, "check_every", "must be >= 1");
  require(max_candidates >= 1, "max_candidates", "must be >= 1");
  require(submap_keyframes >= 0, "submap_keyframes", "must be >= 0");
  require(max_descriptor_distance >= 0.0 && max_descriptor_distance <= 1.0,
          "max_descriptor_distance", "must be in [0, 1]");
  require(min_quality >= 0.0 && min_quality <= 1.0, "min_quality", "must be in [0, 1]");
  require(min_inlier_ratio >= 0.0 && min_inlier_ratio <= 1.0, "min_inlier_ratio",
          "must be in [0, 1]");
  require(finite(max_correction) && max_correction >= 0.0, "max_correction",
          "must be >= 0 [m] (0 = the search radius)");
  require(finite(max_correction_rotation) && max_correction_rotation >= 0.0,
          "max_correction_rotation_deg", "must be >= 0 [deg] (0 = no bound)");
  require(finite(correction_rotation_per_m) && correction_rotation_per_m >= 0.0,
          "correction_rotation_per_m_deg", "must be >= 0 [deg/m]");
  require(finite(information_scale) && information_scale > 0.0, "information_scale", "must be > 0");
  require(finite(floor_sigma_translation) && floor_sigma_translation >= 0.0,
          "floor_sigma_translation", "must be >= 0 [m]");
  require(finite(floor_sigma_rotation) && floor_sigma_rotation >= 0.0, "floor_sigma_rotation_deg",
          "must be >= 0 [deg]");
  require(loss.kind != backend::LossKind::Default, "loss", "must name a loss (none, huber:δ, ...)");
  // dcs:auto (scale 0): Φ calibrated by the optimiser on the graph's own residuals.
  const bool dcs_auto = loss.kind == backend::LossKind::Dcs && loss.scale == 0.0;
  require(dcs_auto || (finite(loss.scale) && loss.scale > 0.0), "loss",
          "scale must be > 0 (or dcs:auto)");
  descriptor.validate();
  relocalisation.validate();
}

RelocalisationParams RelocalisationParams::load(const ConfigNode& node) {
  node.checkKeys({"enabled", "max_descriptor_distance", "max_candidates", "min_quality",
                  "min_inlier_ratio", "confirmations", "agreement_translation",
                  "agreement_rotation_deg"});
  RelocalisationParams p;
  node.get("enabled", p.enabled);
  node.get("max_descriptor_distance", p.max_descriptor_distance);
  node.get("max_candidates", p.max_candidates);
  node.get("min_quality", p.min_quality);
  node.get("min_inlier_ratio", p.min_inlier_ratio);
  node.get("confirmations", p.confirmations);
  node.get("agreement_translation", p.agreement_translation);
  node.getDegAsRad("agreement_rotation_deg", p.agreement_rotation);
  validateAt(node, [&] { p.validate(); });
  return p;
}

LoopClosureParams LoopClosureParams::load(const ConfigNode& node) {
  node.checkKeys({"enabled", "min_travel", "search_radius", "search_radius_per_m",
                  "max_search_radius", "max_view_angle_deg", "check_every", "max_candidates",
                  "cooldown",
                  "submap_keyframes", "use_descriptor", "max_descriptor_distance", "min_quality",
                  "min_inlier_ratio", "max_correction", "max_correction_rotation_deg",
                  "correction_rotation_per_m_deg", "information_scale",
                  "floor_sigma_translation", "floor_sigma_rotation_deg", "loss", "descriptor",
                  "relocalisation"});
  LoopClosureParams p;
  node.get("enabled", p.enabled);
  node.get("min_travel", p.min_travel);
  node.get("search_radius", p.search_radius);
  node.get("search_radius_per_m", p.search_radius_per_m);
  node.get("max_search_radius", p.max_search_radius);
  node.getDegAsRad("max_view_angle_deg", p.max_view_angle);
  node.get("check_every", p.check_every);
  node.get("max_candidates", p.max_candidates);
  node.get("cooldown", p.cooldown);
  node.get("submap_keyframes", p.submap_keyframes);
  node.get("use_descriptor", p.use_descriptor);
  node.get("max_descriptor_distance", p.max_descriptor_distance);
  node.get("min_quality", p.min_quality);
  node.get("min_inlier_ratio", p.min_inlier_ratio);
  node.get("max_correction", p.max_correction);
  node.getDegAsRad("max_correction_rotation_deg", p.max_correction_rotation);
  node.getDegAsRad("correction_rotation_per_m_deg", p.correction_rotation_per_m);
  node.get("information_scale", p.information_scale);
  node.get("floor_sigma_translation", p.floor_sigma_translation);
  node.getDegAsRad("floor_sigma_rotation_deg", p.floor_sigma_rotation);
  if (node.has("loss")) {
    try {
      p.loss = backend::parseLoss(node.required<std::string>("loss"));
    } catch (const ConfigError& e) {
      throw ConfigError(node.where("loss") + ": " + e.what());
    }
  }
  p.descriptor = DescriptorParams::load(node.child("descriptor"));
  p.relocalisation = RelocalisationParams::load(node.child("relocalisation"));
  validateAt(node, [&] { p.validate(); });
  return p;
}

// --- all -------------------------------------------------------------------------------------

std::vector<std::string> FrontendParams::sections() {
  return {"preprocess",   "keyframes", "local_map", "tracking",
          "loop_closure", "matcher",   "optimizer"};
}

void FrontendParams::validate() const {
  preprocess.validate();
  keyframes.validate();
  local_map.validate();
  tracking.validate();
  loop_closure.validate();
}

FrontendParams FrontendParams::load(const ConfigNode& node) {
  FrontendParams p;
  p.preprocess = PreprocessParams::load(node.child("preprocess"));
  p.keyframes = KeyframeParams::load(node.child("keyframes"));
  p.local_map = LocalMapParams::load(node.child("local_map"));
  p.tracking = TrackingParams::load(node.child("tracking"));
  p.loop_closure = LoopClosureParams::load(node.child("loop_closure"));
  if (node.has("matcher")) {
    // `fallback` is this library's key; the rest is obm::ScanMatcherConfig's.
    const ConfigNode m = node.child("matcher");
    YAML::Node copy = YAML::Clone(m.yaml());
    if (copy.IsMap() && copy["fallback"]) {
      p.matcher_fallback =
          registration::parseMatcherKind(m.required<std::string>("fallback"), m.where("fallback"));
      copy.remove("fallback");
    }
    p.matcher = registration::ScanMatcherConfig::load(ConfigNode(copy, m.file(), "matcher"));
  }
  if (node.has("optimizer")) p.optimizer = backend::Options::load(node.child("optimizer"));
  try {
    p.validate();
  } catch (const ConfigError& e) {
    throw ConfigError(node.where() + ": " + e.what());
  }
  return p;
}

}  // namespace obm::frontend
