// The source and build folders of this build, for the tests that read the project's own files
// (configs, models, fuzz regressions) and write scratch files. The two paths are compiled into this
// one translation unit only: every other test object is then the same for every clone and build
// folder, and ccache reuses it (scripts/build.sh).
#include "test_data.hpp"

namespace obm::test {

std::string sourceDir() { return OBM_SOURCE_DIR; }
std::string binaryDir() { return OBM_BINARY_DIR; }

}  // namespace obm::test
