#pragma once
/// \file matcher_stage.hpp
/// The timing stage (StageTimes, timing.json) of the scan matcher's work in the front-end — loop
/// verification and the last_keyframe recovery step: "obmnet" for a matcher that registers
/// without a good guess (OBMNet, OBMNet + ICP), "loop_icp" for the local ones (ICP, OBMM + ICP).
/// Private to libs/frontend.
#include "obm/frontend/stages.hpp"
#include "obm/registration/scan_matcher.hpp"

namespace obm::frontend {

inline Stage matcherStage(const registration::ScanMatcher& matcher) {
  return matcher.global() ? Stage::Obmnet : Stage::LoopIcp;
}

}  // namespace obm::frontend
