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
/// - OpenMP's waiting workers (LibTorch's, OpenBLAS's and Open3D's thread teams):
///   GOMP_SPINCOUNT=300 unless OMP_WAIT_POLICY or GOMP_SPINCOUNT is set. By default libgomp lets
///   a worker that waits for the next parallel region spin for up to 300 000 rounds; when another
///   process needs that core, the spinning and the waiting for a descheduled worker made a
///   2-thread network pass 2-3 times slower, and obm-map, whose ICP runs on threads of its own,
///   lost a quarter of its frame rate even on an idle machine. A short spin keeps the speed of
///   back-to-back parallel regions on an idle machine (sleeping at once, OMP_WAIT_POLICY=PASSIVE,
///   made the realistic object model's pass a third slower there) and gives the cores away
///   soon after (docs/benchmarks.md, "OpenMP's waiting workers").
/// - OpenBLAS (LibTorch's matrix products on Debian) chooses its kernels by the CPU's model and
///   falls back to the oldest (Prescott, SSE3) on a model it does not know, as virtual machines
///   that report a generic "Intel Xeon Processor" are: the network's matrix products then run
///   at half speed or less. When that happened and the CPU has AVX2 and FMA (and AVX-512), this
///   sets OPENBLAS_CORETYPE to Haswell (SkylakeX). Nothing happens when the variable is set,
///   when the BLAS is not OpenBLAS, or when OpenBLAS recognised the CPU.
void useFastMathLibraries(char** argv);

/// The settings useFastMathLibraries manages, as the process runs with them, for a log line:
/// "OMP_WAIT_POLICY=(unset) GOMP_SPINCOUNT=300 OPENBLAS_CORETYPE=(unset)
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
