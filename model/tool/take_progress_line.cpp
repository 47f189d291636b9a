#include "model/tool/take_progress_line.h"

#include <unistd.h>

namespace mm::tool {

TakeProgressLine::TakeProgressLine(std::FILE* out, std::string what, int64_t windows)
    : out_(out), draw_(::isatty(::fileno(out)) == 1), what_(std::move(what)), windows_(windows) {}

std::string TakeProgressLine::line(const std::string& what, int64_t done, int64_t windows, double seconds) {
  const int64_t percent = windows > 0 ? (done >= windows ? 100 : done * 100 / windows) : 0;
  return what + ": " + std::to_string(done) + " of " + std::to_string(windows) + " windows (" +
         std::to_string(percent) + "%), " + std::to_string(static_cast<int64_t>(seconds)) + " s";
}

void TakeProgressLine::window_done() {
  ++done_;
  if (!draw_) return;
  const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start_).count();
  const std::string text = line(what_, done_, windows_, seconds);
  // Padded over a longer line drawn before.
  std::fprintf(out_, "\r%s%*s", text.c_str(), static_cast<int>(width_ > text.size() ? width_ - text.size() : 0), "");
  std::fflush(out_);
  width_ = text.size();
}

void TakeProgressLine::finish() {
  if (width_ == 0) return;
  std::fprintf(out_, "\r%*s\r", static_cast<int>(width_), "");
  std::fflush(out_);
  width_ = 0;
}

}  // namespace mm::tool
