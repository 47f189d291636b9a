// A training job's progress as the user watches it: on a terminal one line
// redrawn in place (bar, iteration, losses, it/s, ETA); otherwise (a pipe,
// a log file) one plain line per change, so logs stay readable. Not thread
// safe.
#pragma once

#include <cstdio>
#include <string>

#include "motionmanifold/v1/manifold.pb.h"

namespace mm::client {

namespace v1 = motionmanifold::v1;

class ProgressDisplay {
 public:
  // Draws on `out`; `redraw` picks the terminal form.
  ProgressDisplay(std::FILE* out, bool redraw) : out_(out), redraw_(redraw) {}

  // Shows a record; plain output skips records that changed nothing shown.
  void show(const v1::Job& job);
  // Ends the redrawn line before other output (a reconnect note, the end).
  void break_line();

 private:
  std::FILE* out_;
  bool redraw_;
  bool line_open_ = false;
  std::string last_plain_;
};

// "1:02:03" or "2:03" for seconds (ETA).
std::string format_duration(double seconds);
// The progress text without the bar: "running 12/30 (40%) loss_a 0.1 ... 3.2 it/s ETA 0:05".
std::string progress_text(const v1::Job& job);

}  // namespace mm::client
