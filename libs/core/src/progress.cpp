#include "obm/core/progress.hpp"

#include <unistd.h>

#include <cmath>
#include <cstdio>
#include <sstream>

namespace obm {

ProgressBar::ProgressBar(std::size_t total, std::string label, std::string unit)
    : total_(total), label_(std::move(label)), unit_(std::move(unit)), tty_(isatty(2) != 0) {}

ProgressBar::~ProgressBar() {
  if (!finished_ && done_ > 0) finish(status_);
}

std::string ProgressBar::formatDuration(double s) {
  if (!std::isfinite(s) || s < 0) return "--:--";
  const long t = static_cast<long>(std::lround(s));
  char buf[32];
  if (t >= 3600)
    std::snprintf(buf, sizeof buf, "%ld:%02ld:%02ld", t / 3600, (t / 60) % 60, t % 60);
  else
    std::snprintf(buf, sizeof buf, "%ld:%02ld", t / 60, t % 60);
  return buf;
}

void ProgressBar::update(std::size_t done, const std::string& status) {
  done_ = done;
  if (!status.empty()) status_ = status;
  const double now = timer_.seconds();
  const double period = tty_ ? 0.1 : 10.0;
  if (now - last_draw_s_ >= period || (total_ > 0 && done_ >= total_)) {
    last_draw_s_ = now;
    draw(false);
  }
}

void ProgressBar::finish(const std::string& status) {
  if (!status.empty()) status_ = status;
  draw(true);
  finished_ = true;
}

void ProgressBar::draw(bool final) {
  if (!enabled_) return;
  const double el = timer_.seconds();
  const double rate = el > 0 ? static_cast<double>(done_) / el : 0.0;
  std::ostringstream os;
  os << label_ << " ";
  if (total_ > 0) {
    const double frac = std::min(1.0, static_cast<double>(done_) / static_cast<double>(total_));
    const int width = 24;
    const int filled = static_cast<int>(frac * width);
    os << "[" << std::string(static_cast<std::size_t>(filled), '#')
       << std::string(static_cast<std::size_t>(width - filled), '.') << "] " << done_ << "/"
       << total_ << " (" << static_cast<int>(100 * frac) << "%)";
    const double eta = rate > 0 ? static_cast<double>(total_ - std::min(done_, total_)) / rate : NAN;
    char r[64];
    std::snprintf(r, sizeof r, " %.1f %s/s", rate, unit_.c_str());
    os << r << " elapsed " << formatDuration(el) << " ETA " << (final ? "0:00" : formatDuration(eta));
  } else {
    char r[64];
    std::snprintf(r, sizeof r, " %zu %s, %.1f %s/s", done_, unit_.c_str(), rate, unit_.c_str());
    os << r << " elapsed " << formatDuration(el);
  }
  if (!status_.empty()) os << " | " << status_;
  const std::string line = os.str();
  if (tty_)
    std::fprintf(stderr, "\r\033[K%s%s", line.c_str(), final ? "\n" : "");
  else
    std::fprintf(stderr, "%s\n", line.c_str());
  std::fflush(stderr);
}

}  // namespace obm
