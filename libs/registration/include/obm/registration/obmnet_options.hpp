#pragma once
/// \file obmnet_options.hpp
/// The registrar's options a matcher runs with, for code that runs the registrar itself
/// (obm-bench's network-alone rows) with exactly the settings the matchers use.
#include "obm/obmnet/registrar.hpp"
#include "obm/registration/obmnet_matcher.hpp"

namespace obm::registration {

/// `params.network`, checked. `network_alone`: the options of ObmNetMatcher, whose pose is the
/// network's own; the matchers that refine judge the hypotheses by their refinements, so
/// `min_consensus` is off for them (a start kept by it would take from ICP the hypothesis it
/// could still have registered).
/// Throws ConfigError on an empty model path, negative num_points or threads < 1.
obmnet::ObmNetRegistrar::Options registrarOptions(const ObmNetMatcherParams& params,
                                                  bool network_alone);

}  // namespace obm::registration
