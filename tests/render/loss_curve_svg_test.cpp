// Specification of the training-log reader and the loss-curve chart.
#include "model/render/loss_curve_svg.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cmath>
#include <string>

#include "format/input_error.h"
#include "tests/common/test_environment.h"

namespace mm::render {
namespace {

using ::testing::HasSubstr;

const char* const kLog =
    "iteration,learning_rate,L_ang,L_pos,L_R,L_M,L_W,L_G,L_D,total\n"
    "100,0.0001,0.5,40,0.01,0.2,0.1,0.7,0.7,42\n"
    "200,0.0001,0.4,30,0.01,0.15,0.1,0.69,0.69,31\n"
    "300,9e-05,0.3,nan,0.01,0.1,0.1,0.68,0.7,inf\r\n"
    "\n";

size_t count_of(const std::string& text, const std::string& needle) {
  size_t count = 0;
  for (size_t at = text.find(needle); at != std::string::npos; at = text.find(needle, at + 1)) ++count;
  return count;
}

TEST(LossLog, ReadsTheTrainersHeaderAndRows) {
  test::ScratchDir dir;
  const LossLog log = read_loss_log(dir.write("train_log.csv", kLog));
  ASSERT_EQ(log.columns.size(), 10u);
  EXPECT_EQ(log.columns[0], "iteration");
  EXPECT_EQ(log.column_index("L_pos"), 3);
  EXPECT_EQ(log.column_index("L_X"), -1);
  ASSERT_EQ(log.rows.size(), 3u);
  EXPECT_DOUBLE_EQ(log.rows[1][0], 200);
  EXPECT_DOUBLE_EQ(log.rows[2][1], 9e-5);
  EXPECT_TRUE(std::isnan(log.rows[2][3]));  // a diverged value is data, not a parse error
  EXPECT_TRUE(std::isinf(log.rows[2][9]));
}

TEST(LossLog, LineWithMissingValueIsAnInputErrorNamingFileAndLine) {
  test::ScratchDir dir;
  const std::string path = dir.write("train_log.csv",
                                     "iteration,L_ang,L_pos\n"
                                     "100,0.5,40\n"
                                     "200,0.4\n");
  try {
    read_loss_log(path);
    FAIL() << "expected InputError";
  } catch (const InputError& e) {
    EXPECT_THAT(e.what(), HasSubstr(path + ":3:"));
    EXPECT_THAT(e.what(), HasSubstr("expected 3 values, found 2"));
  }
}

TEST(LossLog, ValueThatIsNotANumberIsAnInputErrorNamingLineColumnAndValue) {
  try {
    parse_loss_log("iteration,L_ang\n100,0.5\n200,0.4x\n", "log.csv");
    FAIL() << "expected InputError";
  } catch (const InputError& e) {
    EXPECT_THAT(e.what(), HasSubstr("log.csv:3:"));
    EXPECT_THAT(e.what(), HasSubstr("L_ang"));
    EXPECT_THAT(e.what(), HasSubstr("\"0.4x\""));
  }
}

TEST(LossLog, EmptyFileOrHeaderWithoutIterationIsAnInputError) {
  EXPECT_THROW(parse_loss_log("", "log.csv"), InputError);
  EXPECT_THROW(parse_loss_log("step,L_ang\n1,2\n", "log.csv"), InputError);
  EXPECT_THROW(parse_loss_log("iteration,L_ang,L_ang\n1,2,3\n", "log.csv"), InputError);
}

TEST(LossCurvesSvg, DrawsOnePanelPerChosenColumn) {
  const LossLog log = parse_loss_log(kLog, "train_log.csv");
  CurveOptions options;
  options.title = "run 1";
  const std::string svg = render_loss_curves_svg(log, {"L_ang", "L_pos", "L_D"}, options);
  EXPECT_EQ(svg.rfind("<svg", 0), 0u);
  EXPECT_EQ(svg.substr(svg.size() - 7), "</svg>\n");
  EXPECT_THAT(svg, HasSubstr(">L_ang</text>"));
  EXPECT_THAT(svg, HasSubstr(">L_pos</text>"));
  EXPECT_THAT(svg, HasSubstr(">L_D</text>"));
  EXPECT_THAT(svg, HasSubstr(">run 1</text>"));
  EXPECT_EQ(count_of(svg, ">iteration</text>"), 3u);
  // L_pos has a NaN in its last row: two points remain, one polyline.
  EXPECT_EQ(count_of(svg, "class=\"curve\""), 3u);
}

TEST(LossCurvesSvg, SmoothingDrawsTheRawValuesFaintlyBehindTheAverage) {
  const LossLog log = parse_loss_log(kLog, "train_log.csv");
  CurveOptions options;
  options.smooth_window = 2;
  const std::string svg = render_loss_curves_svg(log, {"L_ang"}, options);
  EXPECT_EQ(count_of(svg, "class=\"raw\""), 1u);
  EXPECT_EQ(count_of(svg, "class=\"curve\""), 1u);
}

TEST(LossCurvesSvg, LogScaleLabelsDecades) {
  const LossLog log = parse_loss_log("iteration,L\n1,0.002\n2,0.5\n3,30\n", "log.csv");
  CurveOptions options;
  options.log_scale = true;
  const std::string svg = render_loss_curves_svg(log, {"L"}, options);
  for (const char* decade : {">0.001</text>", ">0.01</text>", ">0.1</text>", ">1</text>", ">10</text>", ">100</text>"}) {
    EXPECT_THAT(svg, HasSubstr(decade));
  }
}

TEST(LossCurvesSvg, UnknownColumnIsAnInputErrorListingTheColumns) {
  const LossLog log = parse_loss_log(kLog, "train_log.csv");
  try {
    render_loss_curves_svg(log, {"L_ang", "L_foo"}, CurveOptions{});
    FAIL() << "expected InputError";
  } catch (const InputError& e) {
    EXPECT_THAT(e.what(), HasSubstr("L_foo"));
    EXPECT_THAT(e.what(), HasSubstr("L_pos"));
  }
  EXPECT_THROW(render_loss_curves_svg(parse_loss_log("iteration,L\n", "x"), {"L"}, CurveOptions{}), InputError);
}

}  // namespace
}  // namespace mm::render
