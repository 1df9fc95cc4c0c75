#include "obm/frontend/rejection.hpp"

namespace obm::frontend {

const char* toString(RejectionKind kind) {
  switch (kind) {
    case RejectionKind::None:
      return "none";
    case RejectionKind::NoSweep:
      return "no_sweep";
    case RejectionKind::MatchStatus:
      return "match_status";
    case RejectionKind::NonFinitePose:
      return "non_finite_pose";
    case RejectionKind::Quality:
      return "quality";
    case RejectionKind::InlierRatio:
      return "inlier_ratio";
    case RejectionKind::TranslationJump:
      return "translation_jump";
    case RejectionKind::RotationJump:
      return "rotation_jump";
    case RejectionKind::DescriptorDistance:
      return "descriptor_distance";
    case RejectionKind::LoopCorrection:
      return "loop_correction";
    case RejectionKind::LoopRotationCorrection:
      return "loop_rotation_correction";
    case RejectionKind::NotConfirmed:
      return "not_confirmed";
  }
  return "?";
}

}  // namespace obm::frontend
