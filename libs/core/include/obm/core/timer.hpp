#pragma once
/// \file timer.hpp
/// Wall-clock stopwatch and a per-stage timing accumulator (for timing.json reports).
#include <chrono>
#include <map>
#include <string>

namespace obm {

class Timer {
 public:
  Timer() : start_(Clock::now()) {}
  void reset() { start_ = Clock::now(); }
  double seconds() const { return std::chrono::duration<double>(Clock::now() - start_).count(); }
  double ms() const { return 1e3 * seconds(); }

 private:
  using Clock = std::chrono::steady_clock;
  Clock::time_point start_;
};

/// Accumulates total milliseconds and call counts per named stage.
class StageTimes {
 public:
  struct Entry {
    double total_ms = 0.0;
    std::size_t count = 0;
  };
  void add(const std::string& stage, double ms) {
    auto& e = entries_[stage];
    e.total_ms += ms;
    ++e.count;
  }
  const std::map<std::string, Entry>& entries() const { return entries_; }

 private:
  std::map<std::string, Entry> entries_;
};

/// RAII: adds the scope's duration to a StageTimes entry.
class ScopedStage {
 public:
  ScopedStage(StageTimes& times, std::string stage) : times_(times), stage_(std::move(stage)) {}
  ~ScopedStage() { times_.add(stage_, timer_.ms()); }
  ScopedStage(const ScopedStage&) = delete;
  ScopedStage& operator=(const ScopedStage&) = delete;

 private:
  StageTimes& times_;
  std::string stage_;
  Timer timer_;
};

}  // namespace obm
