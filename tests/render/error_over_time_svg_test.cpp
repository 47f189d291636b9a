// A take's per-frame error over time as SVG (render/error_over_time_svg.h).
#include "model/render/error_over_time_svg.h"

#include <regex>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "format/input_error.h"

namespace mm::render {
namespace {

using ::testing::HasSubstr;

int count_of(const std::string& text, const std::string& what) {
  int n = 0;
  for (size_t at = text.find(what); at != std::string::npos; at = text.find(what, at + 1)) ++n;
  return n;
}

TEST(ErrorOverTimeSvg, DrawsEveryFrameOfEverySeriesAtItsTimeAndTheMarks) {
  ErrorSeries crossfade{"crossfade", "#1f77b4", std::vector<float>(251, 20.0f)};
  ErrorSeries cut{"cut", "#d62728", std::vector<float>(251, 30.0f)};
  cut.values[125] = 80.0f;  // the peak sets the axis: 0 to 80 mm
  ErrorChartOptions options;
  options.frame_rate = 25;  // 251 frames: 10 s
  options.title = "walking_1";
  options.marks_seconds = {3.0, 6.0};
  const std::string svg = render_error_over_time_svg({crossfade, cut}, options);
  EXPECT_EQ(count_of(svg, "<polyline"), 2);
  EXPECT_EQ(count_of(svg, "stroke-dasharray"), 2);
  EXPECT_THAT(svg, HasSubstr(">walking_1<"));
  EXPECT_THAT(svg, HasSubstr(">crossfade<"));
  EXPECT_THAT(svg, HasSubstr(">80<"));
  EXPECT_THAT(svg, HasSubstr(">10<"));  // the last second on the time axis
  // 251 points a curve; the peak at the top of the plot (y = 40, the plot's
  // upper edge under a title), halfway along (x = 60 + 5/10 of 880).
  const std::regex polyline("points=\"([^\"]*)\"");
  int points = 0;
  for (auto it = std::sregex_iterator(svg.begin(), svg.end(), polyline); it != std::sregex_iterator(); ++it) {
    points += count_of((*it)[1].str(), ",");
  }
  EXPECT_EQ(points, 2 * 251);
  EXPECT_THAT(svg, HasSubstr("500,40 "));
}

TEST(ErrorOverTimeSvg, NothingToDrawIsRefused) {
  EXPECT_THROW(render_error_over_time_svg({}, {}), InputError);
  EXPECT_THROW(render_error_over_time_svg({{"empty", "#000", {}}}, {}), InputError);
  ErrorChartOptions zero_rate;
  zero_rate.frame_rate = 0;
  EXPECT_THROW(render_error_over_time_svg({{"one", "#000", {1.0f}}}, zero_rate), InputError);
}

}  // namespace
}  // namespace mm::render
