#include "model/tool/progress_line.h"

#include <unistd.h>

#include <cmath>

namespace mm::tool {

std::string format_duration(double seconds) {
  if (!std::isfinite(seconds) || seconds < 0) return "?";
  const auto s = static_cast<long long>(std::llround(seconds));
  char text[32];
  if (s < 60) {
    std::snprintf(text, sizeof text, "%llds", s);
  } else if (s < 3600) {
    std::snprintf(text, sizeof text, "%lldm%02llds", s / 60, s % 60);
  } else {
    std::snprintf(text, sizeof text, "%lldh%02lldm", s / 3600, (s % 3600) / 60);
  }
  return text;
}

ProgressLine::ProgressLine(std::FILE* out) : out_(out), redraw_(isatty(fileno(out)) != 0) {}

void ProgressLine::update(int64_t iteration, int64_t total, const std::map<std::string, double>& losses,
                          double iterations_per_second, double eta_seconds) {
  std::string line;
  char buffer[96];
  const double fraction = total > 0 ? static_cast<double>(iteration) / static_cast<double>(total) : 0;
  if (redraw_) {
    constexpr int kBarWidth = 20;
    const int filled = static_cast<int>(fraction * kBarWidth);
    line += '[';
    for (int i = 0; i < kBarWidth; ++i) line += i < filled ? '#' : '.';
    line += "] ";
  }
  std::snprintf(buffer, sizeof buffer, "%lld/%lld (%.1f%%)", static_cast<long long>(iteration),
                static_cast<long long>(total), 100 * fraction);
  line += buffer;
  // The terms of Eq. 15 and 16 that tell whether training is healthy.
  static const std::pair<const char*, const char*> kShown[] = {
      {"total", "total"}, {"L_ang", "ang"}, {"L_pos", "pos"}, {"L_M", "M"}, {"L_W", "W"}, {"L_G", "G"}, {"L_D", "D"}};
  for (const auto& [key, label] : kShown) {
    const auto found = losses.find(key);
    if (found == losses.end()) continue;
    std::snprintf(buffer, sizeof buffer, "  %s %.4g", label, found->second);
    line += buffer;
  }
  if (iterations_per_second >= 1) {
    std::snprintf(buffer, sizeof buffer, "  %.2f it/s", iterations_per_second);
  } else {
    std::snprintf(buffer, sizeof buffer, "  %.2f s/it", iterations_per_second > 0 ? 1 / iterations_per_second : 0.0);
  }
  line += buffer;
  line += "  ETA " + (iteration >= total ? std::string("0s") : format_duration(eta_seconds));

  if (redraw_) {
    const size_t width = line.size();
    if (width < last_width_) line.append(last_width_ - width, ' ');  // wipe the longer previous line
    last_width_ = width;
    std::fprintf(out_, "\r%s", line.c_str());
    open_ = true;
  } else {
    std::fprintf(out_, "%s\n", line.c_str());
  }
  std::fflush(out_);
}

void ProgressLine::finish() {
  if (open_) std::fputc('\n', out_);
  open_ = false;
  last_width_ = 0;
  std::fflush(out_);
}

}  // namespace mm::tool
