#include "format/motion_text.h"
#include "format/motion_text_rows.h"

#include <chrono>
#include <sstream>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "format/input_error.h"
#include "tests/common/test_environment.h"

namespace mm {
namespace {

using ::testing::AllOf;
using ::testing::HasSubstr;

std::string line_of(int values, const std::string& fill = "0.1000000") {
  std::string line;
  for (int i = 0; i < values; ++i) line += (i ? "," : "") + fill;
  return line + "\n";
}

// Runs read_motion_text on a file with `content` and returns the error message.
std::string read_error(const std::string& name, const std::string& content) {
  test::ScratchDir dir;
  const std::string path = dir.write(name, content);
  try {
    read_motion_text(path);
  } catch (const InputError& error) {
    return error.what();
  }
  ADD_FAILURE() << "no InputError for " << name;
  return "";
}

TEST(MotionText, ParsesRealFileWithFrameCountFromManifest) {
  MM_REQUIRE_H36M();
  const auto start = std::chrono::steady_clock::now();
  const MotionFrames motion = read_motion_text((test::h36m_dataset_dir() / "S5" / "walking_1.txt").string());
  const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  EXPECT_EQ(motion.columns, 99);
  EXPECT_EQ(motion.frame_count(), 3000);  // h36m-MANIFEST.tsv
  // The data set's first frame has zero root translation.
  EXPECT_EQ(motion.frame(0)[0], 0.0f);
  EXPECT_FLOAT_EQ(motion.frame(0)[6], 0.1123065f);
  EXPECT_LT(seconds, 1.0) << "3000 lines should parse in well under a second";
}

TEST(MotionText, RejectsLineWithWrongColumnCount) {
  const std::string message = read_error("walking_1.txt", line_of(99) + line_of(98));
  EXPECT_THAT(message, AllOf(HasSubstr("walking_1.txt:2:"), HasSubstr("expected 99 values, found 98")));
}

TEST(MotionText, RejectsLineWithTooManyColumns) {
  const std::string message = read_error("long.txt", line_of(100));
  EXPECT_THAT(message, AllOf(HasSubstr("long.txt:1:"), HasSubstr("found 100")));
}

TEST(MotionText, RejectsFieldThatIsNotANumberAndQuotesIt) {
  std::string bad = line_of(99);
  bad.replace(bad.find("0.1000000,0.1000000"), 9, "abc");
  const std::string message = read_error("eating_2.txt", line_of(99) + line_of(99) + bad);
  EXPECT_THAT(message, AllOf(HasSubstr("eating_2.txt:3:"), HasSubstr("\"abc\""), HasSubstr("not a number")));
}

TEST(MotionText, RejectsNumberWithTrailingGarbage) {
  std::string bad = line_of(99);
  bad.replace(0, 9, "0.5x");
  EXPECT_THAT(read_error("x.txt", bad), AllOf(HasSubstr("x.txt:1:"), HasSubstr("\"0.5x\"")));
}

TEST(MotionText, RejectsNaN) {
  std::string bad = line_of(99);
  bad.replace(0, 9, "nan");
  EXPECT_THAT(read_error("nan.txt", line_of(99) + bad),
              AllOf(HasSubstr("nan.txt:2:"), HasSubstr("\"nan\""), HasSubstr("finite")));
}

TEST(MotionText, RejectsInfinity) {
  std::string bad = line_of(99);
  bad.replace(0, 9, "-inf");
  EXPECT_THAT(read_error("inf.txt", bad), AllOf(HasSubstr("inf.txt:1:"), HasSubstr("\"-inf\"")));
}

TEST(MotionText, RejectsValueOutOfFloatRange) {
  std::string bad = line_of(99);
  bad.replace(0, 9, "1e999");
  EXPECT_THAT(read_error("huge.txt", bad), AllOf(HasSubstr("huge.txt:1:"), HasSubstr("\"1e999\"")));
}

// 1e38 is a float but no joint angle: it would overflow forward kinematics.
TEST(MotionText, RejectsRotationBeyondTheBoundNamingLineAndColumn) {
  std::string bad = line_of(99);
  bad.replace(bad.size() - 10, 9, "1e38");  // the last value, a rotation
  EXPECT_THAT(read_error("wild.txt", line_of(99) + bad),
              AllOf(HasSubstr("wild.txt:2:"), HasSubstr("value 99 \"1e38\""), HasSubstr("within +-1000 radians")));
  std::string negative = line_of(99);
  negative.replace(30, 9, "-1000.5");  // value 4, the first rotation
  EXPECT_THAT(read_error("neg.txt", negative), AllOf(HasSubstr("neg.txt:1:"), HasSubstr("value 4 \"-1000.5\"")));
}

TEST(MotionText, RejectsRootTranslationBeyondTheBound) {
  std::string bad = line_of(99);
  bad.replace(0, 9, "1e30");
  EXPECT_THAT(read_error("far.txt", bad),
              AllOf(HasSubstr("far.txt:1:"), HasSubstr("value 1 \"1e30\""), HasSubstr("within +-100000 mm")));
}

// The bounds are inclusive and leave room far beyond real data: a root
// translation of 100 m a frame and a rotation of 1000 radians still parse.
TEST(MotionText, AcceptsValuesAtTheBounds) {
  test::ScratchDir dir;
  std::string line = line_of(99);
  line.replace(10, 9, "-100000.0");  // value 2, root translation
  line.replace(30, 9, "1000.0000");  // value 4, rotation
  const MotionFrames motion = read_motion_text(dir.write("edge.txt", line));
  EXPECT_EQ(motion.frame(0)[1], -1e5f);
  EXPECT_EQ(motion.frame(0)[3], 1e3f);
}

TEST(MotionText, AcceptsAUtf8ByteOrderMark) {
  test::ScratchDir dir;
  const MotionFrames motion = read_motion_text(dir.write("bom.txt", "\xEF\xBB\xBF" + line_of(99) + line_of(99)));
  EXPECT_EQ(motion.frame_count(), 2);
  EXPECT_FLOAT_EQ(motion.frame(0)[0], 0.1f);
}

TEST(MotionText, RejectsEmptyFile) {
  EXPECT_THAT(read_error("empty.txt", ""), AllOf(HasSubstr("empty.txt:1:"), HasSubstr("no frames")));
  EXPECT_THAT(read_error("blank.txt", "\n\n  \n"), HasSubstr("blank.txt:1:"));
}

TEST(MotionText, RejectsBlankLineBetweenFrames) {
  EXPECT_THAT(read_error("hole.txt", line_of(99) + "\n" + line_of(99)), HasSubstr("hole.txt:2:"));
}

// Where only a window is needed, rows are counted before a value is parsed
// and only the window's rows are parsed.
TEST(MotionTextRows, AreCountedAgainstANamedLimitWithoutParsingAValue) {
  const std::string text = line_of(99) + line_of(99, "not-a-number") + line_of(99) + "\n\n";
  EXPECT_EQ(count_motion_text_rows(text.data(), text.size(), "three.txt"), 3);
  const auto error = [](const std::string& text, int64_t max_rows) {
    try {
      count_motion_text_rows(text.data(), text.size(), "rows.txt", 99, max_rows);
    } catch (const InputError& e) {
      return std::string(e.what());
    }
    return std::string("no error");
  };
  EXPECT_THAT(error(text, 2), AllOf(HasSubstr("rows.txt:3: more than 2 rows"), HasSubstr("the most a motion text may hold")));
  EXPECT_THAT(error(line_of(99) + line_of(98), 10), HasSubstr("rows.txt:2: expected 99 values, found 98"));
  EXPECT_THAT(error(line_of(99) + "\n" + line_of(99), 10), HasSubstr("rows.txt:2: blank line"));
  EXPECT_THAT(error("\n", 10), HasSubstr("no frames"));
  EXPECT_EQ(kMaxMotionTextRows, 2000000);
}

TEST(MotionTextRows, OnlyTheWindowsRowsAreParsed) {
  std::string text;
  for (int row = 0; row < 6; ++row) text += line_of(3, std::to_string(row) + ".5");
  text += line_of(3, "garbage");  // after the window: never read
  const MotionFrames window = parse_motion_text_rows(text.data(), text.size(), "w.txt", 3, 2, 3);
  ASSERT_EQ(window.frame_count(), 3);
  EXPECT_EQ(window.values, (std::vector<float>{2.5f, 2.5f, 2.5f, 3.5f, 3.5f, 3.5f, 4.5f, 4.5f, 4.5f}));
  const auto error = [&](int64_t first, int64_t count) {
    try {
      parse_motion_text_rows(text.data(), text.size(), "w.txt", 3, first, count);
    } catch (const InputError& e) {
      return std::string(e.what());
    }
    return std::string("no error");
  };
  EXPECT_THAT(error(5, 2), HasSubstr("w.txt:7: value 1 \"garbage\" is not a number"));
  EXPECT_THAT(error(7, 3), HasSubstr("w.txt: 7 rows, fewer than the 10 that rows 7 to 9 need"));
}

TEST(MotionText, RejectsMissingFileNamingIt) {
  try {
    read_motion_text("/nonexistent/dir/walking_9.txt");
    FAIL() << "expected InputError";
  } catch (const InputError& error) {
    EXPECT_THAT(error.what(), HasSubstr("/nonexistent/dir/walking_9.txt"));
  }
}

TEST(MotionText, AcceptsCrLfLineEndsAndTrailingBlankLines) {
  std::string crlf = line_of(3, "1.5");
  crlf.insert(crlf.size() - 1, "\r");
  std::istringstream in(crlf + crlf + "\r\n\n");
  const MotionFrames motion = parse_motion_text(in, "crlf.txt", 3);
  EXPECT_EQ(motion.frame_count(), 2);
  EXPECT_EQ(motion.frame(1)[2], 1.5f);
}

TEST(MotionText, WrittenTextUsesSevenDecimalsLikeTheData) {
  MotionFrames motion;
  motion.columns = 3;
  motion.values = {0.0f, -0.0f, 1.25f, 3.0f, -0.1123065f, 100.0f};
  std::ostringstream out;
  write_motion_text(motion, out);
  EXPECT_EQ(out.str(), "0.0000000,-0.0000000,1.2500000\n3.0000000,-0.1123065,100.0000000\n");
}

TEST(MotionText, FileRoundTripPreservesValues) {
  MM_REQUIRE_H36M();
  const MotionFrames original = read_motion_text((test::h36m_dataset_dir() / "S5" / "walking_1.txt").string());
  test::ScratchDir dir;
  const std::string path = dir.file("copy.txt");
  write_motion_text_file(original, path);
  const MotionFrames copy = read_motion_text(path);
  ASSERT_EQ(copy.columns, original.columns);
  ASSERT_EQ(copy.values.size(), original.values.size());
  // 7 decimals are the data's own precision, so parsing its output again
  // gives the same text and therefore the same floats.
  EXPECT_EQ(copy.values, original.values);
  // No temporary file is left beside the target.
  EXPECT_EQ(std::distance(std::filesystem::directory_iterator(dir.path()), {}), 1);
}

TEST(MotionText, AtomicWriteReplacesExistingFile) {
  test::ScratchDir dir;
  const std::string path = dir.write("out.txt", "old content that is longer than the new one\n");
  MotionFrames motion;
  motion.columns = 1;
  motion.values = {2.0f};
  write_motion_text_file(motion, path);
  EXPECT_EQ(read_motion_text(path, 1).values, std::vector<float>{2.0f});
}

TEST(MotionText, WriteToMissingDirectoryIsInputError) {
  MotionFrames motion;
  motion.values.assign(99, 0.0f);
  EXPECT_THROW(write_motion_text_file(motion, "/nonexistent/dir/out.txt"), InputError);
}

TEST(SplitPhases, PhaseKHoldsEveryFactorthFrameStartingAtK) {
  MotionFrames motion;
  motion.columns = 2;
  for (int i = 0; i < 7; ++i) motion.values.insert(motion.values.end(), {float(i), float(10 * i)});
  const std::vector<MotionFrames> phases = split_phases(motion, 3);
  ASSERT_EQ(phases.size(), 3u);
  EXPECT_EQ(phases[0].values, (std::vector<float>{0, 0, 3, 30, 6, 60}));
  EXPECT_EQ(phases[1].values, (std::vector<float>{1, 10, 4, 40}));
  EXPECT_EQ(phases[2].values, (std::vector<float>{2, 20, 5, 50}));
  for (const MotionFrames& phase : phases) EXPECT_EQ(phase.columns, 2);
}

TEST(SplitPhases, FactorOneIsACopyAndFactorZeroIsRejected) {
  MotionFrames motion;
  motion.columns = 1;
  motion.values = {1, 2, 3};
  EXPECT_EQ(split_phases(motion, 1).at(0).values, motion.values);
  EXPECT_THROW(split_phases(motion, 0), InputError);
}

TEST(SplitPhases, ShortSequenceGivesEmptyLatePhases) {
  MotionFrames motion;
  motion.columns = 1;
  motion.values = {1};
  const auto phases = split_phases(motion, 2);
  EXPECT_EQ(phases[0].frame_count(), 1);
  EXPECT_EQ(phases[1].frame_count(), 0);
}

TEST(MotionText, NanMarksAMissingJointValueOnlyWhereAskedAndNeverInTheRoot) {
  const std::string joints_missing = "0,0,0,nan,0.5,NaN\n1,2,3,0.1,0.2,0.3\n";
  const MotionFrames motion = parse_motion_text_buffer(joints_missing.data(), joints_missing.size(), "take.txt", 6, true);
  ASSERT_EQ(motion.frame_count(), 2);
  EXPECT_TRUE(std::isnan(motion.frame(0)[3]));
  EXPECT_EQ(motion.frame(0)[4], 0.5f);
  EXPECT_TRUE(std::isnan(motion.frame(0)[5]));
  try {
    parse_motion_text_buffer(joints_missing.data(), joints_missing.size(), "take.txt", 6);
    FAIL() << "NaN taken without nan_is_missing";
  } catch (const InputError& e) {
    EXPECT_THAT(e.what(), HasSubstr("take.txt:1: value 4 \"nan\" is not finite"));
  }
  const std::string root_missing = "0,nan,0,0.1,0.2,0.3\n";
  try {
    parse_motion_text_buffer(root_missing.data(), root_missing.size(), "take.txt", 6, true);
    FAIL() << "NaN taken in the root translation";
  } catch (const InputError& e) {
    EXPECT_THAT(e.what(), HasSubstr("take.txt:1: value 2 \"nan\" is not finite"));
    EXPECT_THAT(e.what(), HasSubstr("not a root translation"));
  }
  const std::string infinite = "0,0,0,inf,0.2,0.3\n";
  EXPECT_THROW(parse_motion_text_buffer(infinite.data(), infinite.size(), "take.txt", 6, true), InputError);
}

}  // namespace
}  // namespace mm
