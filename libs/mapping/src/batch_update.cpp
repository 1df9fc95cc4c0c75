#include "batch_update.hpp"

#include <algorithm>
#include <array>

namespace obm::mapping::detail {

void sortUnique48(std::vector<std::uint64_t>& v, std::vector<std::uint64_t>& scratch) {
  const std::size_t n = v.size();
  if (n < 2) return;
  if (n < 4096) {  // a radix pass costs a 64 Ki-entry histogram: not worth it for small inputs
    std::sort(v.begin(), v.end());
  } else {
    scratch.resize(n);
    std::vector<std::uint32_t> count(1u << 16);
    std::vector<std::uint64_t>* src = &v;
    std::vector<std::uint64_t>* dst = &scratch;
    for (int shift = 0; shift < 48; shift += 16) {
      std::fill(count.begin(), count.end(), 0u);
      for (std::uint64_t x : *src) ++count[(x >> shift) & 0xffff];
      std::uint32_t sum = 0;
      for (auto& c : count) {
        const std::uint32_t k = c;
        c = sum;
        sum += k;
      }
      for (std::uint64_t x : *src) (*dst)[count[(x >> shift) & 0xffff]++] = x;
      std::swap(src, dst);
    }
    // Three passes: the sorted data ends in `scratch`.
    v.swap(scratch);
  }
  v.erase(std::unique(v.begin(), v.end()), v.end());
}

}  // namespace obm::mapping::detail
