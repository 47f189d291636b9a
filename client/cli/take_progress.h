// Long work's progress on a terminal (a take's frames coming back, an
// upload's bytes going out): one line on stderr, drawn at once and redrawn
// in place twice a second, with what is done (of what is expected) and the seconds since the
// work began, so that minutes of a server's work are never silence. Nothing is drawn when stderr is not a terminal (a log,
// a pipe, the tests), so output that is read stays as it was.
// Like the tool's progress line (model/tool/progress_line.h), redrawn with
// \r and cleared before the command's own output; thread safe (a ticker
// thread draws while the reply's reader counts frames).
#pragma once

#include <atomic>
#include <condition_variable>
#include <cstdint>
#include <cstdio>
#include <mutex>
#include <string>
#include <thread>

namespace mm::client {

class TakeProgress {
 public:
  // `what` names the operation ("reconstruct walking_1.txt"); `expected`
  // `unit`s of the work (frames of a take's reply, bytes of an upload; 0:
  // unknown, only the time is shown). Draws on `out` when `draw` (by
  // default: when stderr is a terminal).
  TakeProgress(std::FILE* out, bool draw, std::string what, int64_t expected, std::string unit = "frames");
  ~TakeProgress();
  TakeProgress(const TakeProgress&) = delete;
  TakeProgress& operator=(const TakeProgress&) = delete;

  // Whether stderr is a terminal: the default for `draw`.
  static bool stderr_is_terminal();

  // Units done so far (any thread): frames of the reply received, bytes sent.
  void add(int64_t units) { done_ += units; }
  // Stops drawing and clears the line (also done by the destructor).
  void finish();

  // The line drawn: "reconstruct walking_1.txt: 1,024 of 3,000 frames (34%), 12 s".
  static std::string line(const std::string& what, int64_t done, int64_t expected, double seconds,
                          const std::string& unit = "frames");

 private:
  void run();

  std::FILE* out_;
  bool draw_;
  std::string what_;
  int64_t expected_;
  std::string unit_;
  std::atomic<int64_t> done_{0};
  std::mutex mutex_;
  std::condition_variable wake_;
  bool stop_ = false;
  size_t width_ = 0;
  std::thread ticker_;
};

}  // namespace mm::client
