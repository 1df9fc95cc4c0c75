#pragma once
// Deterministic chunked parallel loop: the index range is cut into fixed-size chunks (independent
// of the thread count) and each chunk's partial result lands in its own slot, so a reduction over
// the slots in chunk order gives bit-identical sums for 1 or N threads.
#include <algorithm>
#include <atomic>
#include <cstddef>
#include <exception>
#include <thread>
#include <vector>

namespace obm::detail {

inline std::size_t numChunks(std::size_t n, std::size_t chunk) {
  return (n + chunk - 1) / chunk;
}

/// Calls fn(chunk_index, begin, end) for every chunk of `chunk` indices of [0, n), on up to
/// `threads` threads (the caller's thread is one of them). Rethrows the first exception.
template <typename Fn>
void parallelChunks(std::size_t n, std::size_t chunk, int threads, Fn&& fn) {
  const std::size_t chunks = numChunks(n, chunk);
  const std::size_t workers =
      std::min<std::size_t>(static_cast<std::size_t>(std::max(1, threads)), chunks);
  std::atomic<std::size_t> next{0};
  std::exception_ptr error;
  std::atomic<bool> failed{false};
  auto work = [&] {
    for (;;) {
      const std::size_t c = next.fetch_add(1);
      if (c >= chunks || failed.load()) return;
      try {
        fn(c, c * chunk, std::min(n, (c + 1) * chunk));
      } catch (...) {
        if (!failed.exchange(true)) error = std::current_exception();
        return;
      }
    }
  };
  if (workers <= 1) {
    work();
  } else {
    std::vector<std::thread> pool;
    pool.reserve(workers - 1);
    for (std::size_t t = 1; t < workers; ++t) pool.emplace_back(work);
    work();
    for (auto& th : pool) th.join();
  }
  if (error) std::rethrow_exception(error);
}

}  // namespace obm::detail
