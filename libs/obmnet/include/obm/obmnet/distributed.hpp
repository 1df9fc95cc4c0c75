#pragma once
/// \file distributed.hpp
/// Data-parallel training over several processes with LibTorch's own collective engine (c10d,
/// Gloo on CPU). Every rank holds a full copy of the model, trains on its shard of each batch, and
/// the gradients are averaged by one all-reduce per step, so that all copies stay identical (the
/// scheme of PyTorch's DistributedDataParallel; docs/training.md, "Several processes"). LibTorch
/// stays out of this header; the tensor-level collectives are in collectives.hpp.
#include <memory>
#include <string>
#include <vector>

namespace obm::obmnet {

/// Where and how the ranks of one run meet.
struct DistributedOptions {
  int rank = 0;        ///< this process, 0 … world_size − 1 (rank 0 writes every file)
  int world_size = 1;  ///< processes in the run; 1 = no distribution
  /// TCP rendezvous: rank 0 listens on master_addr:master_port, the others connect to it.
  std::string master_addr = "127.0.0.1";
  int master_port = 29500;
  /// Rendezvous through a file every rank can reach (a shared file system) instead of TCP; the
  /// file must not exist before the run. Empty = TCP.
  std::string init_file;
  /// A collective that a peer does not join within this time fails with an error naming it
  /// (rank 0 validates and writes checkpoints while the others wait at the next step).
  double timeout_s = 1800.0;

  /// The usual environment of a distributed launch: RANK, WORLD_SIZE, MASTER_ADDR, MASTER_PORT,
  /// and OBM_DIST_FILE / OBM_DIST_TIMEOUT for the file rendezvous and the timeout. Without
  /// WORLD_SIZE (or with 1): a single process. Throws ConfigError naming the variable when one is
  /// malformed or out of range.
  static DistributedOptions fromEnvironment();
  /// Throws ConfigError when a value is out of range.
  void validate() const;
};

/// One process's membership in a run: the rendezvous is made by the constructor (it blocks until
/// every rank has arrived, or fails after `timeout_s`).
class ProcessGroup {
 public:
  /// Throws obm::Error naming the address (or file) and the rank when the rendezvous fails.
  explicit ProcessGroup(const DistributedOptions& options);
  ~ProcessGroup();
  ProcessGroup(const ProcessGroup&) = delete;
  ProcessGroup& operator=(const ProcessGroup&) = delete;

  int rank() const;
  int worldSize() const;
  const DistributedOptions& options() const;

  /// Sums `values` element-wise over all ranks, in place (every rank gets the sums). Collective:
  /// every rank must call it with the same number of values. Throws obm::Error naming this rank
  /// when a peer has exited or timed out.
  void allReduceSum(std::vector<double>& values);
  /// Waits until every rank has arrived here.
  void barrier();

  struct Impl;
  Impl& impl() { return *impl_; }

 private:
  std::unique_ptr<Impl> impl_;
};

}  // namespace obm::obmnet
