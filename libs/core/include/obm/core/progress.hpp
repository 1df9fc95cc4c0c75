#pragma once
/// \file progress.hpp
/// A terminal progress bar with rate and ETA, written to stderr (never stdout). On a terminal it
/// redraws one line; otherwise (CI logs, pipes) it prints a line at most every `log_period_s`.
#include <cstddef>
#include <iosfwd>
#include <string>

#include "obm/core/timer.hpp"

namespace obm {

class ProgressBar {
 public:
  /// \param total number of steps (0 = unknown)
  /// \param label shown before the bar
  /// \param unit  what a step is ("frames", "pairs"), used in the rate
  ProgressBar(std::size_t total, std::string label, std::string unit = "it");
  ~ProgressBar();

  /// Sets the current count and an extra status text (e.g. "loss 0.012 kf 31"); redraws if due.
  void update(std::size_t done, const std::string& status = {});
  /// Advances by one.
  void tick(const std::string& status = {}) { update(done_ + 1, status); }
  /// Draws the final state and a newline.
  void finish(const std::string& status = {});

  /// Disables all output (for quiet modes and tests).
  void setEnabled(bool on) { enabled_ = on; }

  /// Formats seconds as h:mm:ss or m:ss.
  static std::string formatDuration(double s);

 private:
  void draw(bool final);
  std::size_t total_, done_ = 0;
  std::string label_, unit_, status_;
  Timer timer_;
  double last_draw_s_ = -1e9;
  bool tty_;
  bool enabled_ = true;
  bool finished_ = false;
};

}  // namespace obm
