#include "source_tree.hpp"

#ifndef OBM_SIM_SOURCE_CONFIG_DIR
#define OBM_SIM_SOURCE_CONFIG_DIR ""
#endif
#ifndef OBM_SIM_SOURCE_SHARED_DATA
#define OBM_SIM_SOURCE_SHARED_DATA ""
#endif
#ifndef OBM_SIM_INSTALL_DATADIR
#define OBM_SIM_INSTALL_DATADIR "share"
#endif

namespace obm::sim::detail {

std::string sourceConfigDir() { return OBM_SIM_SOURCE_CONFIG_DIR; }
std::string sourceSharedData() { return OBM_SIM_SOURCE_SHARED_DATA; }
std::string installDataDir() { return OBM_SIM_INSTALL_DATADIR; }

}  // namespace obm::sim::detail
