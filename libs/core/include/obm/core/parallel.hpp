#pragma once
/// \file parallel.hpp
/// The project's one parallel loop over independent tasks (std::thread, no pool). Tasks are
/// claimed from an atomic counter; a task writes its result into its own slot, so the output does
/// not depend on the thread count. The first exception is re-thrown in the caller.
#include <algorithm>
#include <atomic>
#include <cstddef>
#include <exception>
#include <mutex>
#include <thread>
#include <vector>

namespace obm {

/// `requested` threads, or the hardware's when `requested` <= 0 (at least 1).
inline int resolveThreads(int requested) {
  if (requested > 0) return requested;
  const unsigned hw = std::thread::hardware_concurrency();
  return hw == 0 ? 1 : static_cast<int>(hw);
}

/// Calls task(i) for every i in [0, n_tasks) on up to resolveThreads(threads) threads (the
/// caller's thread is one of them).
template <typename F>
void parallelFor(std::size_t n_tasks, int threads, F&& task) {
  const int nt = static_cast<int>(std::min<std::size_t>(
      static_cast<std::size_t>(std::max(1, resolveThreads(threads))), n_tasks));
  if (nt <= 1) {
    for (std::size_t i = 0; i < n_tasks; ++i) task(i);
    return;
  }
  std::atomic<std::size_t> next{0};
  std::atomic<bool> failed{false};
  std::exception_ptr error;
  std::mutex error_mutex;
  auto worker = [&] {
    for (;;) {
      const std::size_t i = next.fetch_add(1);
      if (i >= n_tasks || failed.load()) return;
      try {
        task(i);
      } catch (...) {
        std::lock_guard<std::mutex> lock(error_mutex);
        if (!error) error = std::current_exception();
        failed = true;
      }
    }
  };
  std::vector<std::thread> pool;
  pool.reserve(static_cast<std::size_t>(nt - 1));
  for (int t = 1; t < nt; ++t) pool.emplace_back(worker);
  worker();
  for (auto& th : pool) th.join();
  if (error) std::rethrow_exception(error);
}

/// Number of chunks of `chunk` indices that cover [0, n).
inline std::size_t numChunks(std::size_t n, std::size_t chunk) { return (n + chunk - 1) / chunk; }

/// Deterministic chunked loop for reductions: [0, n) is cut into chunks of `chunk` indices (a size
/// independent of the thread count) and fn(chunk_index, begin, end) is called for each, on up to
/// `threads` threads (<= 0: one). Summing per-chunk partial results in chunk order gives
/// bit-identical totals for 1 or N threads.
template <typename Fn>
void parallelChunks(std::size_t n, std::size_t chunk, int threads, Fn&& fn) {
  parallelFor(numChunks(n, chunk), std::max(1, threads),
              [&](std::size_t c) { fn(c, c * chunk, std::min(n, (c + 1) * chunk)); });
}

}  // namespace obm
