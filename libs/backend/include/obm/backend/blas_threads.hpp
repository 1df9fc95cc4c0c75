#pragma once
/// \file blas_threads.hpp
/// Single-threaded BLAS for the duration of a sparse solve.
///
/// Ceres' SuiteSparse back-end (CHOLMOD supernodal) calls dense BLAS on every front. Behind
/// Debian's OpenMP build of OpenBLAS (which LibTorch wants for its own GEMMs), each of those many
/// small calls forks an OpenMP team; when the cores are busy, the team's threads spin-wait on each
/// other: sphere2500 took 2748 ms instead of 274 ms while one training run used the 2 cores. The
/// fronts of pose graphs are small, so one thread loses nothing on an idle machine either.
namespace obm::backend {

/// Sets the calling thread's OpenMP team size (which the OpenMP build of OpenBLAS follows) to 1
/// and restores it on destruction. A no-op when built without OpenMP.
class ScopedSingleThreadedBlas {
 public:
  ScopedSingleThreadedBlas();
  ~ScopedSingleThreadedBlas();
  ScopedSingleThreadedBlas(const ScopedSingleThreadedBlas&) = delete;
  ScopedSingleThreadedBlas& operator=(const ScopedSingleThreadedBlas&) = delete;

 private:
  int saved_ = 0;
};

}  // namespace obm::backend
