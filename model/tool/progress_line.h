// The training progress display on stderr: on a terminal one line redrawn in
// place (\r) with a bar; otherwise (a log file, a pipe) one plain line per
// report, so logs stay readable. Torch-free. Not thread safe: one trainer
// thread reports to it.
#pragma once

#include <cstdint>
#include <cstdio>
#include <map>
#include <string>

namespace mm::tool {

class ProgressLine {
 public:
  // Redraws in place when `out` is a terminal.
  explicit ProgressLine(std::FILE* out);

  // `losses` by name as the trainer reports them (total, L_ang, L_pos, L_M,
  // L_W, L_D, ...); missing names are left out.
  void update(int64_t iteration, int64_t total, const std::map<std::string, double>& losses,
              double iterations_per_second, double eta_seconds);
  // Ends a redrawn line so that later output starts on a fresh one.
  void finish();

 private:
  std::FILE* out_;
  bool redraw_;
  bool open_ = false;
  size_t last_width_ = 0;
};

// "42s", "3m05s", "2h07m".
std::string format_duration(double seconds);

}  // namespace mm::tool
