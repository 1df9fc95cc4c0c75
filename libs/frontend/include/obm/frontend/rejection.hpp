#pragma once
/// \file rejection.hpp
/// Why a registration was not taken: the acceptance test it failed, as a value a program can
/// branch on, and the numbers in words for frames.csv / loops.csv and the log.
#include <string>

namespace obm::frontend {

/// The acceptance test a registration (tracking, recovery, loop closure, relocalisation) failed.
enum class RejectionKind {
  None,                       ///< accepted
  NoSweep,                    ///< the frame gave no usable sweep (too few points, or none yet)
  MatchStatus,                ///< the matcher failed (status other than ok / not converged)
  NonFinitePose,              ///< the pose has NaN or infinite entries
  Quality,                    ///< MatchResult::quality below the bound
  InlierRatio,                ///< inlier ratio below the (absolute or relative) bound
  TranslationJump,            ///< tracking: too far from the constant-velocity guess
  RotationJump,               ///< tracking: turned too far from the constant-velocity guess
  DescriptorDistance,         ///< loop: the place descriptors differ too much
  LoopCorrection,             ///< loop: the verified pose moves the estimate too far
  LoopRotationCorrection,     ///< loop: the verified pose turns the estimate too far
  NotConfirmed,               ///< relocalisation: the next keyframes did not agree (yet)
};

/// "none", "no_sweep", "match_status", "non_finite_pose", "quality", "inlier_ratio",
/// "translation_jump", "rotation_jump", "descriptor_distance", "loop_correction",
/// "loop_rotation_correction", "not_confirmed".
const char* toString(RejectionKind kind);

/// A failed (or passed) acceptance test.
struct Rejection {
  RejectionKind kind = RejectionKind::None;
  std::string detail;  ///< the test's numbers in words ("" when accepted)

  bool rejected() const { return kind != RejectionKind::None; }
  static Rejection accepted() { return {}; }
};

}  // namespace obm::frontend
