#include "cli.hpp"

#include <dlfcn.h>
#include <signal.h>
#include <time.h>
#include <unistd.h>

#include <CLI/CLI.hpp>
#include <cctype>
#include <cstdlib>
#include <exception>
#include <iostream>
#include <string>

#include "obm/core/errors.hpp"

namespace {

// Constant-initialised (no static-initialisation order to worry about) and lock-free, so the
// handler's store is async-signal-safe.
std::atomic<bool> g_cancel{false};
static_assert(std::atomic<bool>::is_always_lock_free,
              "the signal handler may only touch a lock-free atomic");

std::atomic<long long> g_first_signal_ms{0};
static_assert(std::atomic<long long>::is_always_lock_free,
              "the signal handler may only touch lock-free atomics");

long long monotonicMs() {  // clock_gettime is async-signal-safe
  timespec ts{};
  clock_gettime(CLOCK_MONOTONIC, &ts);
  return static_cast<long long>(ts.tv_sec) * 1000 + ts.tv_nsec / 1000000;
}

extern "C" void onCancelSignal(int sig) {
  // The first signal asks the app to stop at its next safe point and write what it has. A second
  // one at least a second later (the user pressing Ctrl-C again) ends the process at once, as
  // command-line tools do; signals closer together are one event (a terminal's Ctrl-C reaches
  // obm-train's launcher and its ranks, and the launcher forwards it too). _exit is
  // async-signal-safe; files being written are temporaries, so nothing half-written is left
  // under its final name.
  const long long now = monotonicMs();
  if (!g_cancel.exchange(true)) {
    g_first_signal_ms.store(now);
    return;
  }
  if (now - g_first_signal_ms.load() >= 1000) {
    static const char msg[] = "\ninterrupted again: exiting now\n";
    (void)!::write(2, msg, sizeof msg - 1);
    ::_exit(128 + sig);
  }
}

/// The whole line in one piece, so that it is not interleaved with other output (the ranks of
/// obm-train share the terminal).
void printLine(const std::string& line) {
  std::cerr << line << std::flush;
}

}  // namespace

namespace obm::apps {

namespace {

/// The kernels OpenBLAS chose ("Haswell", "Prescott", ...), or "" when the BLAS is another.
std::string openBlasCoreName() {
  using CoreName = char* (*)();
  const auto corename = reinterpret_cast<CoreName>(dlsym(RTLD_DEFAULT, "openblas_get_corename"));
  return corename == nullptr ? std::string() : std::string(corename());
}

/// OPENBLAS_CORETYPE for a CPU OpenBLAS did not recognise (useFastMathLibraries), or nullptr.
const char* fasterBlasCore() {
  std::string name = openBlasCoreName();
  for (char& c : name) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  // Another BLAS (""), or a known CPU: OpenBLAS's own choice stands.
  if (name != "prescott") return nullptr;
#if defined(__GNUC__) && (defined(__x86_64__) || defined(__i386__))
  __builtin_cpu_init();
  if (!(__builtin_cpu_supports("avx2") && __builtin_cpu_supports("fma"))) return nullptr;
  const bool avx512 = __builtin_cpu_supports("avx512f") && __builtin_cpu_supports("avx512bw") &&
                      __builtin_cpu_supports("avx512dq") && __builtin_cpu_supports("avx512vl");
  return avx512 ? "SkylakeX" : "Haswell";
#else
  return nullptr;
#endif
}

}  // namespace

void useFastMathLibraries(char** argv) {
  bool changed = false;
  if (std::getenv("OMP_WAIT_POLICY") == nullptr && std::getenv("GOMP_SPINCOUNT") == nullptr)
    changed |= setenv("GOMP_SPINCOUNT", "300", 1) == 0;
  if (std::getenv("OPENBLAS_CORETYPE") == nullptr) {  // unset: neither the user nor a first run
    if (const char* core = fasterBlasCore()) changed |= setenv("OPENBLAS_CORETYPE", core, 1) == 0;
  }
  // After the second start both are set (or OpenBLAS runs its own choice), so this runs once.
  // execv returns only on failure: go on with the libraries as they were loaded.
  if (changed) execv("/proc/self/exe", argv);
}

std::string mathLibrarySettings() {
  std::string out;
  for (const char* name : {"OMP_WAIT_POLICY", "GOMP_SPINCOUNT", "OPENBLAS_CORETYPE"}) {
    const char* value = std::getenv(name);
    out += std::string(out.empty() ? "" : " ") + name + "=" + (value ? value : "(unset)");
  }
  const std::string core = openBlasCoreName();
  out += " OpenBLAS core=" + (core.empty() ? std::string("(not OpenBLAS)") : core);
  return out;
}

std::atomic<bool>& installCancelHandler() {
  static const bool installed = [] {
    struct sigaction sa {};
    sa.sa_handler = onCancelSignal;
    sigemptyset(&sa.sa_mask);
    sa.sa_flags = SA_RESTART;  // what std::signal does on glibc: interrupted reads resume
    sigaction(SIGINT, &sa, nullptr);
    sigaction(SIGTERM, &sa, nullptr);
    return true;
  }();
  (void)installed;
  return g_cancel;
}

void addLogLevelOption(CLI::App& app, std::string& level, const std::string& default_level) {
  level = default_level;
  app.add_option("--log-level", level,
                 "debug, info, warn, error or off [default: " + default_level + "]");
}

int runMain(const std::string& app_name, OtherExceptions other, const std::function<int()>& body) {
  try {
    return body();
  } catch (const obm::Error& e) {
    printLine(app_name + ": error: " + e.what() + "\n");
    return 1;
  } catch (const std::exception& e) {
    if (other == OtherExceptions::Error) {
      printLine(app_name + ": error: " + e.what() + "\n");
      return 1;
    }
    printLine(app_name + ": unexpected error: " + e.what() + "\n");
    return 2;
  }
}

int runMain(const std::string& app_name, const std::function<int()>& body) {
  return runMain(app_name, OtherExceptions::Unexpected, body);
}

}  // namespace obm::apps
