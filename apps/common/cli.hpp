#pragma once
/// \file cli.hpp
/// What every command-line application of apps/ does the same way: Ctrl-C / SIGTERM as a flag
/// the work polls, the `--log-level` option, and exceptions turned into a message on stderr and
/// an exit code. Each app still parses its own command line with CLI11 in its main().
#include <atomic>
#include <functional>
#include <string>

namespace CLI {
class App;
}

namespace obm::apps {

/// Settings of the math libraries that are read only when the libraries are loaded, so that
/// they must be in the environment before the program starts; when one is missing, this sets it
/// and runs the program again with the same arguments (once). Call it first in main().
/// - OpenMP's waiting workers (LibTorch's and OpenBLAS's thread teams): OMP_WAIT_POLICY=PASSIVE
///   unless OMP_WAIT_POLICY or GOMP_SPINCOUNT is set. By default a worker that waits for the
///   next parallel region spins on its core; when another process needs that core, the spinning
///   and the waiting for a descheduled worker made a 2-thread network pass 2-2.7 times slower
///   than on one thread (docs/benchmarks.md, "OpenMP's waiting workers"). Sleeping workers cost
///   a network pass about 10 % on an idle machine; obm-map, whose ICP runs on threads of its
///   own, maps 30-50 % more frames per second with them, idle or not.
/// - OpenBLAS (LibTorch's matrix products on Debian) chooses its kernels by the CPU's model and
///   falls back to the oldest (Prescott, SSE3) on a model it does not know, as virtual machines
///   that report a generic "Intel Xeon Processor" are: the network's matrix products then run
///   at half speed or less. When that happened and the CPU has AVX2 and FMA (and AVX-512), this
///   sets OPENBLAS_CORETYPE to Haswell (SkylakeX). Nothing happens when the variable is set,
///   when the BLAS is not OpenBLAS, or when OpenBLAS recognised the CPU.
void useFastMathLibraries(char** argv);

/// The settings useFastMathLibraries manages, as the process runs with them, for a log line:
/// "OMP_WAIT_POLICY=PASSIVE GOMP_SPINCOUNT=(unset) OPENBLAS_CORETYPE=(unset)
/// OpenBLAS core=Haswell".
std::string mathLibrarySettings();

/// Installs the process's SIGINT and SIGTERM handler (SA_RESTART) and returns the flag it sets.
/// The handler only touches lock-free atomics (async-signal-safe); the work polls the flag and
/// stops at its next check (the apps then exit with status 130). A second signal a second or more
/// after the first ends the process at once (exit 128 + signal number), writing nothing more.
/// Idempotent: later calls return the same flag and install nothing. Call it where the work
/// begins: before that call the signals keep their default action (end the process).
std::atomic<bool>& installCancelHandler();

/// Adds `--log-level LEVEL` (text "debug, info, warn, error or off [default: DEFAULT]") storing
/// into `level`, which is set to `default_level` first. The value is checked later, by
/// obm::parseLogLevel, inside runMain's body (a bad level is an obm::ConfigError, exit code 1).
void addLogLevelOption(CLI::App& app, std::string& level, const std::string& default_level);

/// What runMain makes of an exception that is not an obm::Error.
enum class OtherExceptions {
  Unexpected,  ///< "APP: unexpected error: WHAT" on stderr, exit code 2
  Error,       ///< "APP: error: WHAT" on stderr, exit code 1: the same as an obm::Error
};

/// Runs `body` and returns its exit code. An obm::Error escaping it prints "APP: error: WHAT" on
/// stderr and returns 1; any other std::exception is reported as `other` says. Errors an app
/// reports differently (another message, another exit code) are caught inside its body.
int runMain(const std::string& app_name, OtherExceptions other, const std::function<int()>& body);

/// runMain with OtherExceptions::Unexpected: "APP: unexpected error: WHAT", exit code 2.
int runMain(const std::string& app_name, const std::function<int()>& body);

}  // namespace obm::apps
