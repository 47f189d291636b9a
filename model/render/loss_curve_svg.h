// Loss curves: reading the trainer's log (train_log.csv, written by
// Trainer::append_log) and plotting chosen columns over iterations as an SVG
// chart with one small panel per loss term.
//
// The log has a header line and one line per logged iteration:
//   iteration,learning_rate,L_ang,L_pos,L_R,L_M,L_W,L_G,L_D,total
//   100,0.0001,0.512,38.1,...
// Any header is accepted as long as it has an "iteration" column; values are
// numbers as printed by an ostream ("nan" and "inf" included, since a
// diverging run writes them). All functions here are reentrant.
#pragma once

#include <string>
#include <vector>

namespace mm::render {

// A parsed log. Plain value type.
struct LossLog {
  std::vector<std::string> columns;         // header names, in file order
  std::vector<std::vector<double>> rows;    // one per data line, columns.size() values each

  // Position of `name` in columns, or -1 when absent.
  int column_index(const std::string& name) const;
};

// Reads and parses the log at `path`. Blank lines (and a trailing '\r') are
// ignored. Returns the header and every data line (possibly none).
// Throws InputError naming the file, and "path:line" for a line's errors,
// when: the file cannot be read; it has no header; a header name is empty or
// repeated; the header has no "iteration" column; a line has a different
// number of values than the header (both counts named); or a value is not a
// number (the value and its column named).
LossLog read_loss_log(const std::string& path);

// Same on text already in memory; `source_name` is used in messages.
LossLog parse_loss_log(const std::string& text, const std::string& source_name);

struct CurveOptions {
  double panel_width_px = 320;
  double panel_height_px = 200;
  int panels_per_row = 3;
  // Moving average over this many logged points (trailing window: the value
  // at a point is the mean of it and the window-1 points before it); 1 draws
  // the raw values only. With a window > 1 the raw values are drawn faintly
  // behind the smoothed curve.
  int smooth_window = 1;
  // Logarithmic y axis (base 10). Values <= 0 cannot be placed and are left
  // out of the curve, as are non-finite values on either scale.
  bool log_scale = false;
  std::string title;  // drawn above the panels when not empty
};

// Renders one panel per name in `columns` (in that order; empty means every
// column but "iteration"), each with its own y range, ticks and labels, and
// the iteration on x. Returns an SVG document ("<svg ... </svg>\n"). A panel
// whose column has no drawable value says so instead of a curve.
// Throws InputError when the log has no data rows, a requested column is not
// in the log (naming it and the columns there are), "iteration" is requested,
// or smooth_window < 1, panels_per_row < 1 or a panel size is not positive.
std::string render_loss_curves_svg(const LossLog& log, const std::vector<std::string>& columns,
                                   const CurveOptions& options);

}  // namespace mm::render
