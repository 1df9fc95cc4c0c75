#pragma once
/// \file collectives.hpp
/// The tensor-level collectives of data-parallel training (LibTorch types; see distributed.hpp):
/// what the trainer calls once per step, kept apart so that they can be tested on any module.
#include <torch/torch.h>

#include <vector>

#include "obm/obmnet/distributed.hpp"

namespace obm::obmnet {

/// Averages the gradients of `parameters` over the ranks of `group` in one all-reduce of a
/// flattened buffer. Each rank's gradient is the mean loss gradient of its own `local_pairs`
/// pairs; scaled by local_pairs / global_pairs before the sum, the result is the mean gradient of
/// the union batch of `global_pairs` pairs, exactly as one process would compute it on the union
/// batch when the loss is a mean over pairs (for layers that mix the pairs of a batch, batch
/// normalisation in training mode, each rank normalises with the statistics of its own shard, as
/// DistributedDataParallel does). Parameters without a gradient take part as zeros.
void allReduceGradients(ProcessGroup& group, const std::vector<torch::Tensor>& parameters,
                        int local_pairs, int global_pairs);

/// Copies `tensors` of rank `root` to every other rank (in place). For the initial weights and,
/// before every step, the batch-normalisation buffers (running mean / variance), as
/// DistributedDataParallel's `broadcast_buffers`.
void broadcastTensors(ProcessGroup& group, const std::vector<torch::Tensor>& tensors, int root = 0);

}  // namespace obm::obmnet
