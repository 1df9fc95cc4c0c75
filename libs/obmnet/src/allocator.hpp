#pragma once

namespace obm::obmnet::detail {

/// Keeps the process's freed tensor memory for reuse instead of handing it back to the kernel
/// (glibc: allocations below 32 MB come from the heap, and the heap is trimmed only once 1 GB is
/// free at its top). A network pass allocates and frees tens of megabytes of temporaries; with
/// glibc's defaults each of them is mapped and unmapped again, and on a virtual machine the page
/// faults of touching that memory anew cost more than the arithmetic (docs/benchmarks.md,
/// "Inference cost"). Called by ObmNetRegistrar and Trainer; done once per process; the
/// environment variable OBM_MALLOC_DEFAULTS=1 leaves the allocator as it is. No effect outside
/// glibc.
void keepFreedTensorMemory();

}  // namespace obm::obmnet::detail
