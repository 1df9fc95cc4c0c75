#pragma once
// Where a build in the source tree finds the presets (config/sim) and the reference data
// (../shared/data), and where an install keeps its data. Compiled into source_tree.cpp alone, so
// that the simulator's other objects do not depend on the clone's path (ccache reuses them).
#include <string>

namespace obm::sim::detail {

std::string sourceConfigDir();   ///< <source>/config, "" when not built from a source tree
std::string sourceSharedData();  ///< <source>/../shared/data, "" likewise
std::string installDataDir();    ///< CMAKE_INSTALL_DATADIR ("share")

}  // namespace obm::sim::detail
