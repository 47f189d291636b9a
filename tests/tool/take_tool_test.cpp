// motion-manifold take: a real S5 take through the tool as a user runs it,
// answered frame for frame at its own rate, and bad takes refused with exit
// 2 naming what is wrong.
#include <gtest/gtest.h>

#include <nlohmann/json.hpp>
#include <sstream>
#include <string>
#include <vector>

#include "tests/common/command_run.h"
#include "tests/common/test_environment.h"

namespace mm {
namespace {

const std::string kModel = std::string("--model ") + MM_SHIPPED_MODEL;

test::CommandRun run_tool(const std::string& arguments, const std::string& input = "") {
  return test::run_command(MM_TOOL_PATH, arguments, input);
}

std::string s5(const std::string& name) { return (test::h36m_dataset_dir() / "S5" / name).string(); }

size_t line_count(const std::string& text) {
  size_t lines = 0;
  for (char c : text) lines += c == '\n';
  return lines;
}

// The first `lines` lines of a text file.
std::string first_lines(const std::string& text, size_t lines) {
  size_t at = 0;
  for (size_t i = 0; i < lines && at != std::string::npos; ++i) at = text.find('\n', at) + 1;
  return text.substr(0, at);
}

TEST(ToolTake, ATakeIsAnsweredFrameForFrameAtItsRate) {
  MM_REQUIRE_H36M();
  test::ScratchDir dir;
  // The first 20 s of walking_1 at 50 Hz: 1000 frames, 500 at 25 Hz, six
  // windows (0, 3, 6, 9, 12 and the last at 14 s).
  const std::string take = dir.write("walking.txt", first_lines(test::read_text(s5("walking_1.txt")), 1000));
  auto r = run_tool("take reconstruct " + kModel + " --input " + take + " --out " + dir.file("r.bvh") +
                    " --error-csv " + dir.file("error.csv"));
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(test::read_text(dir.file("r.bvh")).find("Frames: 1000\nFrame Time: 0.02\n"), std::string::npos);
  EXPECT_EQ(line_count(test::read_text(dir.file("error.csv"))), 1001u);  // and its header
  const auto summary = nlohmann::json::parse(r.out);
  EXPECT_EQ(summary.at("frames"), 1000);
  EXPECT_EQ(summary.at("frame_rate"), 50.0);
  EXPECT_EQ(summary.at("windows"), 6);
  EXPECT_GT(summary.at("mean_error_mm").get<double>(), 0.0);

  // The BVH written is a take of its own, read at its Frame Time.
  r = run_tool("take denoise " + kModel + " --input " + dir.file("r.bvh") + " --out " + dir.file("d.txt") +
               " --at-model-rate");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_EQ(line_count(test::read_text(dir.file("d.txt"))), 500u);
  EXPECT_EQ(nlohmann::json::parse(r.out).at("input_rate"), 50.0);

  // A code track, decoded at 120 Hz.
  r = run_tool("take encode " + kModel + " --input " + take + " --out " + dir.file("track.json"));
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const auto track = nlohmann::json::parse(test::read_text(dir.file("track.json")));
  ASSERT_EQ(track.at("windows").size(), 6u);
  EXPECT_EQ(track.at("windows")[1].at("start_seconds"), 3.0);
  EXPECT_EQ(track.at("windows")[5].at("start_seconds"), 14.0);
  EXPECT_EQ(track.at("windows")[1].at("code").size(), 64u);
  EXPECT_EQ(r.err.find("windows ("), std::string::npos) << "progress drawn off a terminal: " << r.err;
  // --input, as the client's track decode and every other command name it
  // (--track as before: the test of bad takes below).
  r = run_tool("take decode " + kModel + " --input " + dir.file("track.json") + " --rate 120 --out " +
               dir.file("decoded.bvh"));
  ASSERT_EQ(r.exit_code, 0) << r.err;
  // 500 frames at 25 Hz (19.96 s) at 120 Hz.
  EXPECT_NE(test::read_text(dir.file("decoded.bvh")).find("Frames: 2396\n"), std::string::npos);
}

// On a terminal (script(1) gives the tool one) a take's windows are counted
// on stderr as they are done, the line cleared before the summary.
// take mirror: the root turns the other way in every frame, the twins
// trade places, and mirrored twice a take is itself (format/motion_mirror.h
// checks the mirror image by forward kinematics).
TEST(ToolTake, AMirroredTakeTurnsTheOtherWayAndMirroredTwiceIsItself) {
  MM_REQUIRE_H36M();
  test::ScratchDir dir;
  const std::string take = dir.write("walking.txt", first_lines(test::read_text(s5("walking_1.txt")), 200));
  auto r = run_tool("take mirror " + kModel + " --input " + take + " --out " + dir.file("mirrored.txt"));
  ASSERT_EQ(r.exit_code, 0) << r.err;
  r = run_tool("take mirror " + kModel + " --input " + dir.file("mirrored.txt") + " --out " + dir.file("back.txt"));
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const auto rows = [](const std::string& text) {
    std::vector<std::vector<double>> out;
    std::istringstream lines(text);
    for (std::string line; std::getline(lines, line);) {
      std::vector<double> row;
      std::istringstream values(line);
      for (std::string v; std::getline(values, v, ',');) row.push_back(std::stod(v));
      out.push_back(row);
    }
    return out;
  };
  const auto original = rows(test::read_text(take)), mirrored = rows(test::read_text(dir.file("mirrored.txt"))),
             back = rows(test::read_text(dir.file("back.txt")));
  ASSERT_EQ(mirrored.size(), 200u);
  ASSERT_EQ(back.size(), 200u);
  for (size_t f = 0; f < original.size(); ++f) {
    EXPECT_EQ(mirrored[f][4], -original[f][4]) << f;  // the turn about the up axis
    EXPECT_EQ(mirrored[f][3 + 3 * 6], original[f][3 + 3 * 1]) << f;  // LeftUpLeg takes RightUpLeg's x
    for (size_t c = 0; c < original[f].size(); ++c) ASSERT_NEAR(back[f][c], original[f][c], 1e-7) << f << ", " << c;
  }
  r = run_tool("take mirror " + kModel + " --input " + take + " --out " + dir.file("mirrored.bvh"));
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(test::read_text(dir.file("mirrored.bvh")).find("Frames: 200\nFrame Time: 0.02\n"), std::string::npos);
}

TEST(ToolTake, OnATerminalATakeShowsTheWindowsDone) {
  MM_REQUIRE_H36M();
  test::ScratchDir dir;
  const std::string take = dir.write("walking.txt", first_lines(test::read_text(s5("walking_1.txt")), 1000));
  const std::string command = std::string(MM_TOOL_PATH) + " take encode " + kModel + " --input " + take + " --out " +
                              dir.file("track.json");
  const auto r = test::run_command("script", "-qec '" + command + "' " + dir.file("typescript"));
  ASSERT_EQ(r.exit_code, 0) << r.out << r.err;
  const std::string shown = test::read_text(dir.file("typescript"));
  EXPECT_NE(shown.find("take encode " + take + ": 6 of 6 windows (100%), "), std::string::npos) << shown;
  EXPECT_NE(shown.find("\r"), std::string::npos) << shown;
  EXPECT_NE(shown.find("\"windows\""), std::string::npos) << "the summary: " << shown;
}

TEST(ToolTake, BadTakesAreExitTwoNamingWhatIsWrong) {
  MM_REQUIRE_H36M();
  test::ScratchDir dir;
  const std::string take = test::read_text(s5("walking_1.txt"));
  const std::string short_take = dir.write("short.txt", first_lines(take, 100));
  auto r = run_tool("take reconstruct " + kModel + " --input " + short_take + " --out " + dir.file("out.txt"));
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.err.find("short.txt: take: 100 frames at 50 Hz"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("expected at least 299 frames"), std::string::npos) << r.err;

  const std::string ten_seconds = dir.write("ten.txt", first_lines(take, 500));
  r = run_tool("take reconstruct " + kModel + " --input " + ten_seconds + " --rate 0 --out " + dir.file("out.txt"));
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.err.find("--rate: expected a frame rate of 10 to 1000 Hz, found 0"), std::string::npos) << r.err;
  r = run_tool("take encode " + kModel + " --input " + ten_seconds + " --hop 7 --out " + dir.file("t.json"));
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.err.find("--hop: expected 0.04 to 6 s"), std::string::npos) << r.err;

  // nan is a missing value for denoise only.
  std::string gapped = first_lines(take, 500);
  const size_t line_start = gapped.find('\n', gapped.size() / 2) + 1;
  const size_t value = gapped.find(',', gapped.find(',', gapped.find(',', line_start) + 1) + 1) + 1;  // column 3
  gapped.replace(value, gapped.find(',', value) - value, "nan");
  const std::string gapped_file = dir.write("gapped.txt", gapped);
  r = run_tool("take reconstruct " + kModel + " --input " + gapped_file + " --out " + dir.file("out.txt"));
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.err.find("gapped.txt:"), std::string::npos) << r.err;
  r = run_tool("take denoise " + kModel + " --input " + gapped_file + " --keep-observed --iterations 2 --out " + dir.file("out.txt"));
  EXPECT_EQ(r.exit_code, 0) << r.err;
  EXPECT_EQ(line_count(test::read_text(dir.file("out.txt"))), 500u);
  EXPECT_EQ(test::read_text(dir.file("out.txt")).find("nan"), std::string::npos);
  // --gap-fill names one of the fills, and only with --keep-observed.
  r = run_tool("take denoise " + kModel + " --input " + gapped_file + " --keep-observed --gap-fill spline --out " +
               dir.file("out.txt"));
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.err.find("--gap-fill: expected \"borrowed\", \"fitted\", \"matched\""), std::string::npos) << r.err;
  r = run_tool("take denoise " + kModel + " --input " + gapped_file + " --gap-fill matched --out " + dir.file("out.txt"));
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.err.find("--gap-fill: applies with --keep-observed only"), std::string::npos) << r.err;

  const std::string unsorted = dir.write(
      "unsorted.json", nlohmann::json{{"windows", {{{"start_seconds", 0}, {"code", std::vector<double>(64, 0.0)}},
                                                   {{"start_seconds", 9}, {"code", std::vector<double>(64, 0.0)}}}}}
                           .dump());
  r = run_tool("take decode " + kModel + " --track " + unsorted + " --out " + dir.file("out.txt"));
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.err.find("unsorted.json: windows[1].start_seconds: expected at most 6 s"), std::string::npos) << r.err;
}

}  // namespace
}  // namespace mm
