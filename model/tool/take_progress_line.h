// A long take's progress on a terminal: one line on stderr with the windows
// done (of those the take has) and the seconds so far, redrawn in place as
// each batch of windows is done, so that minutes of work are never silence.
// Nothing is drawn when the stream is not a terminal (a log, a pipe, the
// tests), so output that is read stays as it was. Torch-free. Not thread
// safe: the take's processing thread reports to it.
#pragma once

#include <chrono>
#include <cstdint>
#include <cstdio>
#include <string>

namespace mm::tool {

class TakeProgressLine {
 public:
  // `what` names the work ("take reconstruct walking_1.txt"); `windows` the
  // take's windows. Draws on `out` when it is a terminal.
  TakeProgressLine(std::FILE* out, std::string what, int64_t windows);
  ~TakeProgressLine() { finish(); }
  TakeProgressLine(const TakeProgressLine&) = delete;
  TakeProgressLine& operator=(const TakeProgressLine&) = delete;

  // One more window done.
  void window_done();
  // Clears the line before the command's own output (also the destructor's).
  void finish();

  // The line drawn: "take reconstruct walking_1.txt: 5 of 19 windows (26%), 12 s".
  static std::string line(const std::string& what, int64_t done, int64_t windows, double seconds);

 private:
  std::FILE* out_;
  bool draw_;
  std::string what_;
  int64_t windows_, done_ = 0;
  size_t width_ = 0;
  std::chrono::steady_clock::time_point start_ = std::chrono::steady_clock::now();
};

}  // namespace mm::tool
