#include "client/cli/take_progress.h"

#include <unistd.h>

#include <chrono>

namespace mm::client {

namespace {

std::string grouped(int64_t value) {
  std::string digits = std::to_string(value);
  for (int at = static_cast<int>(digits.size()) - 3; at > 0; at -= 3) digits.insert(static_cast<size_t>(at), ",");
  return digits;
}

}  // namespace

TakeProgress::TakeProgress(std::FILE* out, bool draw, std::string what, int64_t expected, std::string unit)
    : out_(out), draw_(draw), what_(std::move(what)), expected_(expected), unit_(std::move(unit)) {
  if (draw_) ticker_ = std::thread([this] { run(); });
}

TakeProgress::~TakeProgress() { finish(); }

bool TakeProgress::stderr_is_terminal() { return ::isatty(STDERR_FILENO) == 1; }

std::string TakeProgress::line(const std::string& what, int64_t done, int64_t expected, double seconds,
                               const std::string& unit) {
  std::string text = what + ": ";
  if (expected > 0) {
    const int64_t percent = done >= expected ? 100 : done * 100 / expected;
    text += grouped(done) + " of " + grouped(expected) + " " + unit + " (" + std::to_string(percent) + "%), ";
  } else if (done > 0) {
    text += grouped(done) + " " + unit + ", ";
  } else {
    text += "waiting for the server, ";
  }
  return text + std::to_string(static_cast<int64_t>(seconds)) + " s";
}

void TakeProgress::run() {
  const auto start = std::chrono::steady_clock::now();
  std::unique_lock<std::mutex> lock(mutex_);
  // Drawn at once, then twice a second: work shown from its start.
  do {
    const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    const std::string text = line(what_, done_.load(), expected_, seconds, unit_);
    // Padded over a longer line drawn before.
    std::fprintf(out_, "\r%s%*s", text.c_str(), static_cast<int>(width_ > text.size() ? width_ - text.size() : 0),
                 "");
    std::fflush(out_);
    width_ = text.size();
  } while (!wake_.wait_for(lock, std::chrono::milliseconds(500), [this] { return stop_; }));
}

void TakeProgress::finish() {
  if (!ticker_.joinable()) return;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    stop_ = true;
  }
  wake_.notify_all();
  ticker_.join();
  if (width_ > 0) {
    std::fprintf(out_, "\r%*s\r", static_cast<int>(width_), "");
    std::fflush(out_);
  }
}

}  // namespace mm::client
