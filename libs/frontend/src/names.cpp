// The names of the front-end's enums: rejections and timing stages.
#include "obm/frontend/rejection.hpp"
#include "obm/frontend/stages.hpp"

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

const char* toString(Stage stage) {
  switch (stage) {
    case Stage::Preprocess:
      return "preprocess";
    case Stage::Icp:
      return "icp";
    case Stage::StartSearch:
      return "start_search";
    case Stage::LocalMap:
      return "local_map";
    case Stage::LocalMapBuild:
      return "local_map_build";
    case Stage::LocalMapWait:
      return "local_map_wait";
    case Stage::LoopSearch:
      return "loop_search";
    case Stage::Obmnet:
      return "obmnet";
    case Stage::LoopIcp:
      return "loop_icp";
    case Stage::Relocalise:
      return "relocalise";
    case Stage::Graph:
      return "graph";
    case Stage::Read:
      return "read";
    case Stage::OctomapQueue:
      return "octomap_queue";
    case Stage::Octomap:
      return "octomap";
    case Stage::Autosave:
      return "autosave";
    case Stage::Output:
      return "output";
  }
  return "?";
}

}  // namespace obm::frontend
