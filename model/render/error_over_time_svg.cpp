#include "model/render/error_over_time_svg.h"

#include <algorithm>
#include <cmath>
#include <cstdio>

#include "format/input_error.h"
#include "model/render/svg_document.h"

namespace mm::render {
namespace {

std::string label_of(double value) {
  char text[32];
  std::snprintf(text, sizeof text, "%g", value);
  return text;
}

}  // namespace

std::string render_error_over_time_svg(const std::vector<ErrorSeries>& series, const ErrorChartOptions& options) {
  if (series.empty()) throw InputError("error chart: no series to draw");
  if (!(options.frame_rate > 0) || !(options.width_px > 0) || !(options.height_px > 0)) {
    throw InputError("error chart: the frame rate and the size must be positive");
  }
  size_t frames = 0;
  double top = 0;
  for (const ErrorSeries& s : series) {
    if (s.values.empty()) throw InputError("error chart: series '" + s.label + "' has no values");
    frames = std::max(frames, s.values.size());
    for (float v : s.values) {
      if (std::isfinite(v)) top = std::max(top, static_cast<double>(v));
    }
  }
  const double left = 60, right = 20, upper = options.title.empty() ? 20 : 40, lower = 45;
  const double plot_w = options.width_px - left - right, plot_h = options.height_px - upper - lower;
  const double seconds = std::max(1.0, static_cast<double>(frames - 1)) / options.frame_rate;
  const double y_step = nice_tick_step(std::max(top, 1e-9) / 4);
  const double y_top = std::ceil(std::max(top, 1e-9) / y_step) * y_step;
  const double x_step = nice_tick_step(seconds / 8);
  const auto x_of = [&](double t) { return left + t / seconds * plot_w; };
  const auto y_of = [&](double v) { return upper + plot_h - v / y_top * plot_h; };

  SvgDocument svg(options.width_px, options.height_px);
  if (!options.title.empty()) svg.text(options.width_px / 2, 24, options.title, 14, "middle");
  for (double t : options.marks_seconds) {
    if (t >= 0 && t <= seconds) svg.line(x_of(t), upper, x_of(t), upper + plot_h, "#bbb", 0.6, "stroke-dasharray=\"3,3\"");
  }
  for (double v = 0; v <= y_top + y_step * 1e-6; v += y_step) {
    svg.line(left, y_of(v), left + plot_w, y_of(v), "#eee", 1);
    svg.text(left - 6, y_of(v) + 4, label_of(v), 11, "end");
  }
  for (double t = 0; t <= seconds + x_step * 1e-6; t += x_step) {
    svg.line(x_of(t), upper + plot_h, x_of(t), upper + plot_h + 4, "#222", 1);
    svg.text(x_of(t), upper + plot_h + 17, label_of(t), 11, "middle");
  }
  svg.rect(left, upper, plot_w, plot_h, "none", "#222");
  svg.text(left + plot_w / 2, options.height_px - 8, "time (s)", 12, "middle");
  svg.text(14, upper + plot_h / 2, "error (mm)", 12, "middle", "#222",
           "transform=\"rotate(-90 14 " + px(upper + plot_h / 2) + ")\"");
  double legend_x = left + 10;
  for (const ErrorSeries& s : series) {
    std::string points;
    for (size_t f = 0; f < s.values.size(); ++f) {
      if (!std::isfinite(s.values[f])) continue;
      points += px(x_of(f / options.frame_rate)) + "," + px(y_of(s.values[f])) + " ";
    }
    svg.polyline(points, s.color, 1.0);
    svg.line(legend_x, upper + 12, legend_x + 18, upper + 12, s.color, 2);
    svg.text(legend_x + 22, upper + 16, s.label, 11);
    legend_x += 30 + 7.0 * static_cast<double>(s.label.size());
  }
  return svg.finish();
}

}  // namespace mm::render
