// A take's per-frame error over time as an SVG chart: one curve per series
// (e.g. the windows crossfaded and cut), the time in seconds on x, the error
// in mm on y, and a faint vertical line at each mark (e.g. where windows
// meet), so that a seam shows where it is.
//
// Reentrant. Torch-free: it takes the errors already computed.
#pragma once

#include <string>
#include <vector>

namespace mm::render {

struct ErrorSeries {
  std::string label;
  std::string color;          // an SVG color, e.g. "#1f77b4"
  std::vector<float> values;  // one per frame, mm
};

struct ErrorChartOptions {
  double frame_rate = 25;  // of the series' frames, Hz
  double width_px = 960;
  double height_px = 300;
  std::string title;
  std::vector<double> marks_seconds;  // vertical lines
};

// The chart as an SVG document. Throws InputError when there is no series,
// a series is empty, or the frame rate or size is not positive.
std::string render_error_over_time_svg(const std::vector<ErrorSeries>& series, const ErrorChartOptions& options);

}  // namespace mm::render
