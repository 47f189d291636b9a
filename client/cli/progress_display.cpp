#include "client/cli/progress_display.h"

#include <cmath>
#include <map>

namespace mm::client {

std::string format_duration(double seconds) {
  if (!std::isfinite(seconds) || seconds < 0) return "?";
  const long s = std::lround(seconds);
  char text[32];
  if (s >= 3600) {
    std::snprintf(text, sizeof text, "%ld:%02ld:%02ld", s / 3600, s / 60 % 60, s % 60);
  } else {
    std::snprintf(text, sizeof text, "%ld:%02ld", s / 60, s % 60);
  }
  return text;
}

std::string progress_text(const v1::Job& job) {
  const auto& p = job.progress();
  char buffer[128];
  std::string text = job.state();
  if (p.total() > 0) {
    std::snprintf(buffer, sizeof buffer, " %lld/%lld (%.0f%%)", static_cast<long long>(p.iteration()),
                  static_cast<long long>(p.total()), 100.0 * static_cast<double>(p.iteration()) / p.total());
    text += buffer;
  }
  // Sorted by name, so the columns stay put from one redraw to the next.
  const std::map<std::string, double> losses(p.losses().begin(), p.losses().end());
  for (const auto& [name, value] : losses) {
    std::snprintf(buffer, sizeof buffer, " %s %.4g", name.c_str(), value);
    text += buffer;
  }
  if (p.iterations_per_second() > 0) {
    std::snprintf(buffer, sizeof buffer, " %.2f it/s", p.iterations_per_second());
    text += buffer;
  }
  if (job.state() == "running" && p.eta_seconds() > 0) text += " ETA " + format_duration(p.eta_seconds());
  if (job.resumes() > 0) text += " (resumed " + std::to_string(job.resumes()) + "x)";
  if (!job.published_model().empty()) text += " -> model " + job.published_model();
  if (!job.error().empty()) text += ": " + job.error();
  return text;
}

void ProgressDisplay::show(const v1::Job& job) {
  const std::string text = progress_text(job);
  if (!redraw_) {
    if (text == last_plain_) return;
    last_plain_ = text;
    std::fprintf(out_, "job %s %s\n", job.id().c_str(), text.c_str());
    std::fflush(out_);
    return;
  }
  constexpr int kBarWidth = 24;
  const auto& p = job.progress();
  const double fraction = p.total() > 0 ? std::min(1.0, static_cast<double>(p.iteration()) / p.total()) : 0.0;
  const int filled = static_cast<int>(fraction * kBarWidth);
  std::string bar(static_cast<size_t>(filled), '#');
  bar.append(static_cast<size_t>(kBarWidth - filled), '.');
  // \r and erase-to-end-of-line: the new text may be shorter than the old.
  std::fprintf(out_, "\r\033[K[%s] %s", bar.c_str(), text.c_str());
  std::fflush(out_);
  line_open_ = true;
}

void ProgressDisplay::break_line() {
  if (!line_open_) return;
  std::fputc('\n', out_);
  std::fflush(out_);
  line_open_ = false;
}

}  // namespace mm::client
