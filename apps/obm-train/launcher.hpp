#pragma once
/// \file launcher.hpp
/// `obm-train --nproc N`: starts N copies of obm-train on this machine as the ranks of one
/// data-parallel run (the environment of a distributed launch: RANK, WORLD_SIZE, MASTER_ADDR,
/// MASTER_PORT), forwards Ctrl-C / SIGTERM to them, and stops the others when one fails.
#include <string>
#include <vector>

namespace obm::apps {

/// Runs `argv` (the program and its arguments, without --nproc) as `nproc` processes. Rank 0
/// writes to this terminal; rank k > 0 to `log_dir`/rank_k.log. Returns the exit code of the run:
/// 0 when every rank succeeded, else the code of the first rank that failed (the others are sent
/// SIGTERM, then SIGKILL after `grace_s` seconds).
int launchRanks(const std::vector<std::string>& argv, int nproc, const std::string& log_dir,
                double grace_s = 30.0);

/// A TCP port that is free on the loopback interface now (asked of the kernel).
int freeLoopbackPort();

}  // namespace obm::apps
