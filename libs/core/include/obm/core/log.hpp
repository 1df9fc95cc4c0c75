#pragma once
/// \file log.hpp
/// Minimal levelled logger for the libraries that do not link MRPT (core, obmnet, ...). Writes to
/// stderr with a component name; apps set the level. Libraries never print to stdout.
#include <sstream>
#include <string>

namespace obm {

enum class LogLevel { Debug = 0, Info = 1, Warn = 2, Error = 3, Off = 4 };

/// Global threshold (default Info); thread-safe.
void setLogLevel(LogLevel level);
LogLevel logLevel();
/// Parses "debug|info|warn|error|off"; throws ConfigError otherwise.
LogLevel parseLogLevel(const std::string& s);

/// Writes one line "[level] component: message" to stderr if `level` passes the threshold.
void logMessage(LogLevel level, const std::string& component, const std::string& message);

/// Per-key throttle for per-frame loops: returns true at most once every `period_s` per key.
bool logThrottle(const std::string& key, double period_s);

}  // namespace obm

#define OBM_LOG_STREAM_(lvl, comp, expr)                         \
  do {                                                           \
    if (static_cast<int>(lvl) >= static_cast<int>(::obm::logLevel())) { \
      std::ostringstream obm_log_os_;                            \
      obm_log_os_ << expr;                                       \
      ::obm::logMessage(lvl, comp, obm_log_os_.str());           \
    }                                                            \
  } while (0)
#define OBM_LOG_DEBUG(comp, expr) OBM_LOG_STREAM_(::obm::LogLevel::Debug, comp, expr)
#define OBM_LOG_INFO(comp, expr) OBM_LOG_STREAM_(::obm::LogLevel::Info, comp, expr)
#define OBM_LOG_WARN(comp, expr) OBM_LOG_STREAM_(::obm::LogLevel::Warn, comp, expr)
#define OBM_LOG_ERROR(comp, expr) OBM_LOG_STREAM_(::obm::LogLevel::Error, comp, expr)
/// Warn at most once every `period_s` seconds for this call site's key.
#define OBM_LOG_WARN_THROTTLE(comp, period_s, expr)                          \
  do {                                                                       \
    if (::obm::logThrottle(std::string(__FILE__) + std::to_string(__LINE__), period_s)) \
      OBM_LOG_WARN(comp, expr);                                              \
  } while (0)
