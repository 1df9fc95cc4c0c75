#include "allocator.hpp"

#include <cstdlib>
#include <cstring>
#include <mutex>

#if defined(__GLIBC__)
#include <malloc.h>
#endif

#include "obm/core/log.hpp"

namespace obm::obmnet::detail {

void keepFreedTensorMemory() {
  static std::once_flag once;
  std::call_once(once, [] {
    const char* keep_defaults = std::getenv("OBM_MALLOC_DEFAULTS");
    if (keep_defaults && std::strcmp(keep_defaults, "0") != 0 && *keep_defaults != '\0') return;
#if defined(__GLIBC__)
    // 32 MB is the largest mmap threshold glibc accepts (half its arena size); setting it also
    // turns off the threshold's own adaptation, which the trim threshold would otherwise follow.
    const bool ok = mallopt(M_MMAP_THRESHOLD, 32 * 1024 * 1024) == 1 &&
                    mallopt(M_TRIM_THRESHOLD, 1024 * 1024 * 1024) == 1;
    if (!ok) OBM_LOG_DEBUG("obmnet", "mallopt refused the allocator settings; defaults kept");
#endif
  });
}

}  // namespace obm::obmnet::detail
