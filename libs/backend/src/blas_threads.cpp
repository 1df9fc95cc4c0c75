#include "obm/backend/blas_threads.hpp"

#if defined(_OPENMP)
#include <omp.h>
#endif

namespace obm::backend {

ScopedSingleThreadedBlas::ScopedSingleThreadedBlas() {
#if defined(_OPENMP)
  saved_ = omp_get_max_threads();
  omp_set_num_threads(1);
#endif
}

ScopedSingleThreadedBlas::~ScopedSingleThreadedBlas() {
#if defined(_OPENMP)
  omp_set_num_threads(saved_);
#endif
}

}  // namespace obm::backend
