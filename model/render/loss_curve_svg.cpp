#include "model/render/loss_curve_svg.h"

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <limits>

#include "format/atomic_file.h"
#include "format/input_error.h"
#include "model/render/svg_document.h"

namespace mm::render {
namespace {

const char* const kPalette[] = {"#1f77b4", "#d62728", "#2ca02c", "#9467bd", "#ff7f0e", "#8c564b", "#e377c2",
                                "#17becf"};
constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

// Plot area inside a panel.
constexpr double kPlotLeft = 58, kPlotRight = 14, kPlotTop = 28, kPlotBottom = 38;
constexpr double kMarginPx = 10, kTitlePx = 28;

std::string trim(const std::string& s) {
  const auto first = s.find_first_not_of(" \t");
  if (first == std::string::npos) return "";
  return s.substr(first, s.find_last_not_of(" \t") - first + 1);
}

std::vector<std::string> split_commas(const std::string& line) {
  std::vector<std::string> fields;
  size_t begin = 0;
  while (true) {
    const size_t comma = line.find(',', begin);
    fields.push_back(trim(line.substr(begin, comma == std::string::npos ? std::string::npos : comma - begin)));
    if (comma == std::string::npos) return fields;
    begin = comma + 1;
  }
}

// A tick label with as many decimals as the step needs; large round numbers
// as "20k", very large or small ones in %g form.
std::string tick_label(double value, double step) {
  char buffer[32];
  if (std::abs(value) < step * 1e-6) return "0";
  if (std::abs(value) >= 1e4 && std::fmod(value, 1000) == 0 && std::abs(value) < 1e7) {
    std::snprintf(buffer, sizeof buffer, "%gk", value / 1000);
  } else if (std::abs(value) >= 1e6 || std::abs(value) < 1e-3) {
    std::snprintf(buffer, sizeof buffer, "%.3g", value);
  } else {
    const int decimals = std::max(0, static_cast<int>(-std::floor(std::log10(step) + 1e-9)));
    std::snprintf(buffer, sizeof buffer, "%.*f", decimals, value);
  }
  return buffer;
}

std::string decade_label(int exponent) {
  char buffer[32];
  if (exponent >= -3 && exponent <= 4) {
    std::snprintf(buffer, sizeof buffer, "%.*f", std::max(0, -exponent), std::pow(10.0, exponent));
  } else {
    std::snprintf(buffer, sizeof buffer, "1e%d", exponent);
  }
  return buffer;
}

std::string value_label(double value) {
  char buffer[32];
  std::snprintf(buffer, sizeof buffer, "%.4g", value);
  return buffer;
}

// Trailing moving average over the finite values of each window.
std::vector<double> moving_average(const std::vector<double>& values, int window) {
  if (window <= 1) return values;
  std::vector<double> out(values.size(), kNaN);
  for (size_t i = 0; i < values.size(); ++i) {
    double sum = 0;
    int count = 0;
    for (size_t k = i + 1 > static_cast<size_t>(window) ? i + 1 - window : 0; k <= i; ++k) {
      if (std::isfinite(values[k])) {
        sum += values[k];
        ++count;
      }
    }
    if (count > 0) out[i] = sum / count;
  }
  return out;
}

struct Axis {
  double low = 0, high = 1;
  std::vector<std::pair<double, std::string>> ticks;  // position in axis units, label
};

// A linear axis over [low, high]; `extend` widens it to whole ticks.
Axis linear_axis(double low, double high, bool extend) {
  if (!(high > low)) {
    const double pad = low == 0 ? 1 : std::abs(low) * 0.1;
    low -= pad;
    high += pad;
  }
  const double step = nice_tick_step((high - low) / 4);
  Axis axis;
  axis.low = extend ? std::floor(low / step) * step : low;
  axis.high = extend ? std::ceil(high / step) * step : high;
  for (double t = std::ceil(axis.low / step) * step; t <= axis.high + step * 1e-6; t += step) {
    axis.ticks.emplace_back(t, tick_label(t, step));
  }
  return axis;
}

// A base-10 log axis in units of log10(value), over whole decades.
Axis log_axis(double low, double high) {
  Axis axis;
  axis.low = std::floor(std::log10(low));
  axis.high = std::ceil(std::log10(high));
  if (axis.high <= axis.low) axis.high = axis.low + 1;
  const int decades = static_cast<int>(axis.high - axis.low);
  const int every = decades > 6 ? (decades + 5) / 6 : 1;
  for (int e = static_cast<int>(axis.low); e <= static_cast<int>(axis.high); e += every) {
    axis.ticks.emplace_back(e, decade_label(e));
  }
  return axis;
}

}  // namespace

int LossLog::column_index(const std::string& name) const {
  const auto it = std::find(columns.begin(), columns.end(), name);
  return it == columns.end() ? -1 : static_cast<int>(it - columns.begin());
}

LossLog parse_loss_log(const std::string& text, const std::string& source) {
  LossLog log;
  bool have_header = false;
  size_t begin = 0;
  for (int line_number = 1; begin < text.size(); ++line_number) {
    const size_t end = std::min(text.find('\n', begin), text.size());
    std::string line = text.substr(begin, end - begin);
    begin = end + 1;
    if (!line.empty() && line.back() == '\r') line.pop_back();
    if (trim(line).empty()) continue;
    const std::string where = source + ":" + std::to_string(line_number) + ": ";
    std::vector<std::string> fields = split_commas(line);
    if (!have_header) {
      for (size_t i = 0; i < fields.size(); ++i) {
        if (fields[i].empty()) throw InputError(where + "header: column " + std::to_string(i + 1) + " has no name");
        if (std::find(fields.begin(), fields.begin() + i, fields[i]) != fields.begin() + i) {
          throw InputError(where + "header: column \"" + fields[i] + "\" appears twice");
        }
      }
      log.columns = std::move(fields);
      if (log.column_index("iteration") < 0) {
        throw InputError(where + "header: expected an \"iteration\" column, found \"" + line + "\"");
      }
      have_header = true;
      continue;
    }
    if (fields.size() != log.columns.size()) {
      throw InputError(where + "expected " + std::to_string(log.columns.size()) + " values, found " +
                       std::to_string(fields.size()));
    }
    std::vector<double> row(fields.size());
    for (size_t i = 0; i < fields.size(); ++i) {
      char* stop = nullptr;
      errno = 0;
      row[i] = std::strtod(fields[i].c_str(), &stop);
      if (fields[i].empty() || stop != fields[i].c_str() + fields[i].size()) {
        throw InputError(where + log.columns[i] + ": expected a number, found \"" + fields[i] + "\"");
      }
    }
    log.rows.push_back(std::move(row));
  }
  if (!have_header) throw InputError(source + ": empty, expected a header line starting with \"iteration\"");
  return log;
}

LossLog read_loss_log(const std::string& path) { return parse_loss_log(read_whole_file(path), path); }

std::string render_loss_curves_svg(const LossLog& log, const std::vector<std::string>& requested,
                                   const CurveOptions& o) {
  if (o.smooth_window < 1) throw InputError("loss curves: smoothing window must be >= 1, found " +
                                            std::to_string(o.smooth_window));
  if (o.panels_per_row < 1) throw InputError("loss curves: panels per row must be >= 1, found " +
                                             std::to_string(o.panels_per_row));
  if (!(o.panel_width_px > kPlotLeft + kPlotRight + 10) || !(o.panel_height_px > kPlotTop + kPlotBottom + 10)) {
    throw InputError("loss curves: panel size too small: " + std::to_string(o.panel_width_px) + " x " +
                     std::to_string(o.panel_height_px));
  }
  if (log.rows.empty()) throw InputError("loss curves: the log has no data rows");
  const int iteration_column = log.column_index("iteration");
  if (iteration_column < 0) throw InputError("loss curves: the log has no \"iteration\" column");

  std::vector<std::string> columns = requested;
  if (columns.empty()) {
    for (const auto& c : log.columns) if (c != "iteration") columns.push_back(c);
  }
  std::string available;
  for (const auto& c : log.columns) available += (available.empty() ? "" : ", ") + c;
  for (const auto& c : columns) {
    if (c == "iteration") throw InputError("loss curves: \"iteration\" is the x axis, not a curve");
    if (log.column_index(c) < 0) {
      throw InputError("loss curves: no column \"" + c + "\" in the log (it has " + available + ")");
    }
  }
  if (columns.empty()) throw InputError("loss curves: nothing to plot: the log has only \"iteration\"");

  std::vector<double> iterations;
  for (const auto& row : log.rows) iterations.push_back(row[static_cast<size_t>(iteration_column)]);
  double x_low = std::numeric_limits<double>::infinity(), x_high = -x_low;
  for (double x : iterations) {
    if (std::isfinite(x)) {
      x_low = std::min(x_low, x);
      x_high = std::max(x_high, x);
    }
  }
  if (!std::isfinite(x_low)) throw InputError("loss curves: no finite iteration numbers in the log");
  const Axis x_axis = linear_axis(x_low, x_high, false);

  const int panel_columns = std::min<int>(o.panels_per_row, static_cast<int>(columns.size()));
  const int panel_rows = (static_cast<int>(columns.size()) + panel_columns - 1) / panel_columns;
  const double top = kMarginPx + (o.title.empty() ? 0 : kTitlePx);
  SvgDocument svg(2 * kMarginPx + panel_columns * o.panel_width_px, top + panel_rows * o.panel_height_px + kMarginPx);
  if (!o.title.empty()) svg.text(kMarginPx, kMarginPx + 18, o.title, 16, "start", "#222", "font-weight=\"bold\"");

  for (size_t p = 0; p < columns.size(); ++p) {
    const std::string colour = kPalette[p % (sizeof kPalette / sizeof kPalette[0])];
    const size_t column = static_cast<size_t>(log.column_index(columns[p]));
    const double panel_x = kMarginPx + (p % panel_columns) * o.panel_width_px;
    const double panel_y = top + (p / panel_columns) * o.panel_height_px;
    const double left = panel_x + kPlotLeft, right = panel_x + o.panel_width_px - kPlotRight;
    const double plot_top = panel_y + kPlotTop, bottom = panel_y + o.panel_height_px - kPlotBottom;

    // Values in axis units (log10 on a log scale), NaN where not drawable.
    auto to_axis = [&](double v) {
      if (!std::isfinite(v) || (o.log_scale && v <= 0)) return kNaN;
      return o.log_scale ? std::log10(v) : v;
    };
    std::vector<double> raw;
    for (const auto& row : log.rows) raw.push_back(row[column]);
    const std::vector<double> smooth = moving_average(raw, o.smooth_window);

    double low = std::numeric_limits<double>::infinity(), high = -low, last = kNaN;
    for (size_t i = 0; i < raw.size(); ++i) {
      if (!std::isfinite(iterations[i]) || std::isnan(to_axis(raw[i]))) continue;
      low = std::min(low, raw[i]);
      high = std::max(high, raw[i]);
    }
    for (double v : smooth) if (std::isfinite(v)) last = v;

    svg.text(panel_x + kPlotLeft, panel_y + 18, columns[p], 13, "start", colour, "font-weight=\"bold\"");
    if (std::isfinite(last)) svg.text(right, panel_y + 18, "last " + value_label(last), 10, "end", "#666");
    svg.rect(left, plot_top, right - left, bottom - plot_top, "none", "#999999");
    for (const auto& [x, label] : x_axis.ticks) {
      const double sx = left + (x - x_axis.low) / (x_axis.high - x_axis.low) * (right - left);
      svg.line(sx, bottom, sx, bottom + 4, "#999999", 1);
      svg.text(sx, bottom + 15, label, 10, "middle", "#444");
    }
    svg.text((left + right) / 2, bottom + 30, "iteration", 10, "middle", "#666");
    if (!std::isfinite(low)) {
      svg.text((left + right) / 2, (plot_top + bottom) / 2, o.log_scale ? "no positive values" : "no finite values",
               11, "middle", "#999");
      continue;
    }
    const Axis y_axis = o.log_scale ? log_axis(low, high) : linear_axis(low, high, true);
    auto sx = [&](double x) { return left + (x - x_axis.low) / (x_axis.high - x_axis.low) * (right - left); };
    auto sy = [&](double y) { return bottom - (y - y_axis.low) / (y_axis.high - y_axis.low) * (bottom - plot_top); };
    for (const auto& [y, label] : y_axis.ticks) {
      svg.line(left, sy(y), right, sy(y), "#eeeeee", 1);
      svg.line(left - 4, sy(y), left, sy(y), "#999999", 1);
      svg.text(left - 6, sy(y) + 3.5, label, 10, "end", "#444");
    }
    // One polyline per run of drawable points, so gaps stay gaps.
    auto draw = [&](const std::vector<double>& series, double width, const std::string& extra) {
      std::vector<std::pair<double, double>> run;
      auto flush = [&] {
        if (run.size() == 1) svg.circle(run[0].first, run[0].second, width, colour);
        if (run.size() > 1) {
          std::string points;
          for (const auto& [x, y] : run) points += (points.empty() ? "" : " ") + px(x) + "," + px(y);
          svg.polyline(points, colour, width, extra);
        }
        run.clear();
      };
      for (size_t i = 0; i < series.size(); ++i) {
        const double y = to_axis(series[i]);
        if (!std::isfinite(iterations[i]) || std::isnan(y)) {
          flush();
          continue;
        }
        run.emplace_back(sx(iterations[i]), sy(y));
      }
      flush();
    };
    if (o.smooth_window > 1) {
      draw(raw, 1, "class=\"raw\" stroke-opacity=\"0.25\"");
      draw(smooth, 1.8, "class=\"curve\"");
    } else {
      draw(raw, 1.5, "class=\"curve\"");
    }
  }
  return svg.finish();
}

}  // namespace mm::render
