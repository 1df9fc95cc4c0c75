#include "obm/core/log.hpp"

#include <atomic>
#include <chrono>
#include <cstdio>
#include <mutex>
#include <unordered_map>

#include "obm/core/errors.hpp"

namespace obm {
namespace {
std::atomic<int> g_level{static_cast<int>(LogLevel::Info)};
std::mutex g_mutex;
const char* name(LogLevel l) {
  switch (l) {
    case LogLevel::Debug: return "DEBUG";
    case LogLevel::Info: return "INFO";
    case LogLevel::Warn: return "WARN";
    case LogLevel::Error: return "ERROR";
    default: return "";
  }
}
}  // namespace

void setLogLevel(LogLevel level) { g_level = static_cast<int>(level); }
LogLevel logLevel() { return static_cast<LogLevel>(g_level.load()); }

LogLevel parseLogLevel(const std::string& s) {
  if (s == "debug") return LogLevel::Debug;
  if (s == "info") return LogLevel::Info;
  if (s == "warn" || s == "warning") return LogLevel::Warn;
  if (s == "error") return LogLevel::Error;
  if (s == "off" || s == "quiet") return LogLevel::Off;
  throw ConfigError("unknown log level '" + s + "' (expected debug|info|warn|error|off)");
}

void logMessage(LogLevel level, const std::string& component, const std::string& message) {
  if (static_cast<int>(level) < g_level.load()) return;
  std::lock_guard<std::mutex> lock(g_mutex);
  std::fprintf(stderr, "[%s] %s: %s\n", name(level), component.c_str(), message.c_str());
}

bool logThrottle(const std::string& key, double period_s) {
  using Clock = std::chrono::steady_clock;
  static std::unordered_map<std::string, Clock::time_point> last;
  std::lock_guard<std::mutex> lock(g_mutex);
  const auto now = Clock::now();
  auto it = last.find(key);
  if (it != last.end() && std::chrono::duration<double>(now - it->second).count() < period_s)
    return false;
  last[key] = now;
  return true;
}

}  // namespace obm
