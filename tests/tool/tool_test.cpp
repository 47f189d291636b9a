// The motion-manifold command-line tool end to end, as a user runs it: real
// H3.6M files, a real prepared dataset, a short real training run, and the
// exit codes and messages of bad input.
#include <gtest/gtest.h>
#include <sys/wait.h>

#include <algorithm>
#include <array>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <map>
#include <cmath>
#include <nlohmann/json.hpp>
#include <sstream>
#include <string>
#include <vector>

#include "tests/common/command_run.h"
#include "tests/common/test_environment.h"

namespace mm {
namespace {

struct Result {
  int exit_code;
  std::string output;  // stdout and stderr together
};

Result run_tool(const std::string& arguments) {
  const std::string command = std::string(MM_TOOL_PATH) + " " + arguments + " 2>&1";
  FILE* pipe = popen(command.c_str(), "r");
  if (pipe == nullptr) return {-1, "popen failed"};
  std::string output;
  std::array<char, 4096> buffer;
  while (fgets(buffer.data(), buffer.size(), pipe) != nullptr) output += buffer.data();
  const int status = pclose(pipe);
  return {WIFEXITED(status) ? WEXITSTATUS(status) : -1, output};
}

std::string s5(const std::string& name) { return (test::h36m_dataset_dir() / "S5" / name).string(); }

// A run with its standard streams apart, for the commands that write data
// on stdout; `input` (a file) becomes its standard input when given.
using SplitResult = test::CommandRun;
using test::read_text;

SplitResult run_tool_split(const std::string& arguments, const std::string& input = "") {
  return test::run_command(MM_TOOL_PATH, arguments, input);
}

const std::string kModel = std::string("--model ") + MM_SHIPPED_MODEL;

// The code in encode's output (or a code file): {"codes": [[...]]}, the
// shape the client and REST's Decode read too.
std::vector<double> code_of(const std::string& json_text) {
  const auto codes = nlohmann::json::parse(json_text).at("codes");
  EXPECT_EQ(codes.size(), 1u) << json_text;
  return codes.at(0).get<std::vector<double>>();
}

double distance(const std::vector<double>& a, const std::vector<double>& b) {
  double sum = 0;
  for (size_t i = 0; i < a.size(); ++i) sum += (a[i] - b[i]) * (a[i] - b[i]);
  return std::sqrt(sum);
}

// `frames` lines of 99 values: small rotations, no root translation.
std::string synthetic_motion(int frames) {
  std::string text;
  for (int frame = 0; frame < frames; ++frame) {
    for (int c = 0; c < 99; ++c) text += (c ? "," : "") + std::string(c < 3 ? "0.0" : "0.1");
    text += '\n';
  }
  return text;
}

std::vector<std::string> lines_of(const std::string& text) {
  std::vector<std::string> lines;
  std::istringstream in(text);
  for (std::string line; std::getline(in, line);) lines.push_back(line);
  return lines;
}

TEST(Tool, UnknownVariantIsAUsageErrorNamingTheValue) {
  const auto r = run_tool("train --variant XYZ --dataset nowhere.mmd --out /tmp/unused");
  EXPECT_EQ(r.exit_code, 2) << r.output;
  EXPECT_NE(r.output.find("XYZ"), std::string::npos) << r.output;
}

// train's flags replace the configuration's values by the rule a training
// job's spec follows (resolve_train_config), held to the ranges a
// configuration file is held to: refused before the dataset is looked for.
TEST(Tool, TrainFlagsAreHeldToTheConfigurationsRanges) {
  const auto r = run_tool("train --variant D --hidden 70000 --dataset nowhere.mmd --out /tmp/unused");
  EXPECT_EQ(r.exit_code, 2) << r.output;
  EXPECT_NE(r.output.find("--hidden: value 70000 out of range [1, 65536]"), std::string::npos) << r.output;
  EXPECT_EQ(r.output.find("nowhere.mmd"), std::string::npos) << r.output;
}

// evaluate-gaps' bound on the fit's error takes any number above 0, or inf
// for none (as its help and docs/RESULTS.md say); 0 and text are refused
// by name before any input is read.
TEST(Tool, TheFitErrorBoundTakesInfAndRefusesZeroByName) {
  const auto unbounded = run_tool("evaluate-gaps --input nowhere.txt --fit-max-error inf");
  EXPECT_EQ(unbounded.output.find("--fit-max-error"), std::string::npos) << unbounded.output;
  EXPECT_NE(unbounded.output.find("nowhere.txt"), std::string::npos) << unbounded.output;
  for (const std::string value : {"0", "0.3x"}) {
    const auto r = run_tool("evaluate-gaps --input nowhere.txt --fit-max-error " + value);
    EXPECT_EQ(r.exit_code, 2) << r.output;
    EXPECT_NE(r.output.find("--fit-max-error: expected a number above 0 or inf, found " + value), std::string::npos)
        << r.output;
  }
}

TEST(Tool, MissingSubcommandIsAUsageError) { EXPECT_EQ(run_tool("").exit_code, 2); }

// A tiny bench run: every operation is timed and its tensor operations
// counted; inference at batch 1 on the CPU's fused path issues far fewer
// than a training step.
TEST(Tool, BenchTimesAndCountsTheTensorOperationsOfEveryOperation) {
  test::ScratchDir dir;
  const auto r = run_tool("bench --hidden 8 --iterations 1 --device cpu --out " + dir.file("bench.json"));
  ASSERT_EQ(r.exit_code, 0) << r.output;
  std::ifstream in(dir.file("bench.json"));
  const auto results = nlohmann::json::parse(in)["results"];
  // Two training rows, then encode and decode at batch 1 and 30 with the
  // weights unpacked, packed in fp32 and, where the CPU has bf16 dot
  // products, packed in bf16 and in int8; then decodes to motions standing,
  // with the root path, and with the feet planted, at batch 1 and 30.
  ASSERT_TRUE(results.size() == 16u || results.size() == 24u) << results.dump();
  std::map<std::string, int64_t> operations;
  for (const auto& result : results) {
    EXPECT_GT(result["median_ms"].get<double>(), 0.0) << result.dump();
    EXPECT_GT(result["operations"].get<int64_t>(), 0) << result.dump();
    operations[result["operation"].get<std::string>() + " " + std::to_string(result["batch"].get<int>())] =
        result["operations"].get<int64_t>();
  }
  EXPECT_GT(operations.at("training iteration (DKGM) 4"), 2 * operations.at("decode (rotation) (unpacked fp32) 1"));
  // The packed products are oneDNN's, not LibTorch operators: fewer counted.
  EXPECT_LT(operations.at("decode (rotation) (packed fp32) 30"), operations.at("decode (rotation) (unpacked fp32) 30"));
  // The root path is the trajectory network's operations on top.
  EXPECT_GT(operations.at("decode to motions, root path (packed fp32) 30"),
            operations.at("decode to motions, standing (packed fp32) 30"));
}

// bench --root-path: the three decodes to motions and the three parts of
// the root path and the feet, each by the wall clock and by CPU time, at
// batch 1 and 30.
TEST(Tool, BenchOfTheRootPathTimesTheDecodesAndEachPartByClockAndCpuTime) {
  test::ScratchDir dir;
  const auto r = run_tool("bench --root-path --hidden 8 --iterations 1 --out " + dir.file("bench.json"));
  ASSERT_EQ(r.exit_code, 0) << r.output;
  std::ifstream in(dir.file("bench.json"));
  const auto results = nlohmann::json::parse(in)["results"];
  ASSERT_EQ(results.size(), 24u) << results.dump();
  std::map<std::string, double> median;
  for (const auto& result : results) {
    EXPECT_EQ(result["ms"].size(), 10u) << result.dump();  // at least 10 rounds
    median[result["operation"].get<std::string>() + " " + std::to_string(result["batch"].get<int>())] =
        result["median_ms"].get<double>();
  }
  for (const char* part : {"root path: trajectory network", "root path: network, integration, levelling, floor",
                           "feet planted: plant_feet of each motion"}) {
    EXPECT_GT(median.at(std::string(part) + " 30"), 0.0) << part;
    EXPECT_GT(median.at(std::string(part) + ", CPU time 30"), 0.0) << part;
  }
  EXPECT_GT(median.at("decode to motions, root path (packed fp32), CPU time 30"), 0.0);
}

TEST(Tool, PrepareTrainEvaluateAndDecodeOnRealData) {
  MM_REQUIRE_H36M();
  test::ScratchDir dir;
  const std::string dataset = dir.file("h36m.mmd");
  auto r = run_tool("prepare --data " + test::data_dir() + " --train S1 --test S5 --out " + dataset);
  ASSERT_EQ(r.exit_code, 0) << r.output;
  ASSERT_TRUE(std::filesystem::exists(dataset));

  const std::string run = dir.file("run");
  r = run_tool("train --variant DKGM --dataset " + dataset + " --out " + run +
               " --iterations 3 --hidden 16 --batch 4 --device cpu");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  for (const char* file : {"config.json", "train_log.csv", "checkpoint.pt", "model/manifest.json"}) {
    EXPECT_TRUE(std::filesystem::exists(run + "/" + file)) << file;
  }

  // Going on from the exported weights starts at the iteration the manifest records.
  const std::string more = dir.file("more");
  r = run_tool("train --variant DKGM --dataset " + dataset + " --out " + more + " --init-from " + run +
               "/model --iterations 5 --hidden 16 --batch 4 --device cpu");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  {
    std::ifstream manifest(more + "/model/manifest.json");
    const auto provenance = nlohmann::json::parse(manifest)["provenance"];
    EXPECT_EQ(provenance["started_at_iteration"], 3);
    EXPECT_EQ(provenance["iterations"], 5);
  }
  r = run_tool("train --variant DKGM --dataset " + dataset + " --out " + dir.file("wider") + " --init-from " + run +
               "/model --iterations 5 --hidden 32 --batch 4 --device cpu");
  EXPECT_EQ(r.exit_code, 2) << r.output;
  EXPECT_NE(r.output.find("model.hidden"), std::string::npos) << r.output;

  r = run_tool("evaluate --model " + run + "/model --dataset " + dataset + " --clips 3 --out " + dir.file("eval.json"));
  ASSERT_EQ(r.exit_code, 0) << r.output;
  std::ifstream evaluation(dir.file("eval.json"));
  const auto json = nlohmann::json::parse(evaluation);
  EXPECT_EQ(json["clips"], 3);
  EXPECT_EQ(json["decoders"]["rotation"]["E_p"].size(), 5u);
  // Table 1 in the reference's units, with the spread over 5 clip sets.
  EXPECT_EQ(json["decoders"]["rotation"]["paper_units"]["E_r"].size(), 5u);
  EXPECT_EQ(json["decoders"]["rotation"]["paper_units"]["E_p"].size(), 5u);
  EXPECT_EQ(json["seed_spread"]["seeds"].size(), 5u);
  EXPECT_GT(json["seed_spread"]["decoders"]["rotation"]["paper_units"]["E_r"]["std"][0].get<double>(), 0.0);
  // Denoising: the reference's corruption first, then the paper's zeroing.
  const auto& corruptions = json["denoising"]["corruptions"];
  ASSERT_EQ(corruptions.size(), 4u);
  EXPECT_EQ(corruptions[0]["corruption"], "reference");
  EXPECT_EQ(corruptions[1]["corruption"], "zeroed");
  for (const auto& c : corruptions) {
    EXPECT_GT(c["corrupted_mpjpe_mm"].get<double>(), 0.0) << c.dump();
    EXPECT_GT(c["denoised_missing_mpjpe_mm"].get<double>(), 0.0) << c.dump();
    EXPECT_GT(c["filled_missing_mpjpe_mm"].get<double>(), 0.0) << c.dump();
    EXPECT_LT(c["time_interpolation_mpjpe_mm"].get<double>(), c["corrupted_mpjpe_mm"].get<double>()) << c.dump();
  }
  // Dropping values to their mean is the milder corruption.
  EXPECT_LT(corruptions[0]["corrupted_mpjpe_mm"].get<double>(), corruptions[1]["corrupted_mpjpe_mm"].get<double>());

  r = run_tool("denoise --model " + run + "/model --input " + s5("walking_1.txt") + " --out " + dir.file("d.txt"));
  ASSERT_EQ(r.exit_code, 0) << r.output;
  std::ifstream denoised(dir.file("d.txt"));
  int lines = 0;
  for (std::string line; std::getline(denoised, line);) ++lines;
  EXPECT_EQ(lines, 150);
  r = run_tool("denoise --model " + run + "/model --input " + s5("walking_1.txt") +
               " --corrupt-probability 0.5 --corruption zeroed --zeros-are-missing --iterations 2 --keep-observed --out " +
               dir.file("d2.txt"));
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_NE(r.output.find("\"zeros_are_missing\": true"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("\"keep_observed\": true"), std::string::npos) << r.output;
  // The reference's corruption (the default) leaves dropped values at their
  // training mean, where --means-are-missing finds them; filling only those
  // lowers the error (the shipped model's fill; this test's own model has
  // trained for a few steps only).
  r = run_tool("denoise --input " + s5("walking_1.txt") +
               " --corrupt-probability 0.5 --means-are-missing --keep-observed --corrupted-out " + dir.file("c.txt") +
               " --out " + dir.file("d4.txt"));
  ASSERT_EQ(r.exit_code, 0) << r.output;
  {
    const auto report = nlohmann::json::parse(r.output.substr(r.output.find('{')));
    EXPECT_EQ(report["corruption"], "reference");
    EXPECT_EQ(report["means_are_missing"], true);
    EXPECT_LT(report["denoised_mpjpe_mm"].get<double>(), report["corrupted_mpjpe_mm"].get<double>()) << r.output;
  }
  r = run_tool("denoise --model " + run + "/model --input " + s5("walking_1.txt") +
               " --zeros-are-missing --means-are-missing --out " + dir.file("d5.txt"));
  EXPECT_EQ(r.exit_code, 2) << r.output;
  r = run_tool("denoise --model " + run + "/model --input " + s5("walking_1.txt") +
               " --corrupt-probability 0.5 --corruption gaussian --out " + dir.file("d5.txt"));
  EXPECT_EQ(r.exit_code, 2) << r.output;
  EXPECT_NE(r.output.find("gaussian"), std::string::npos) << r.output;
  r = run_tool("denoise --model " + run + "/model --input " + s5("walking_1.txt") +
               " --zeros-are-missing --iterations 0 --out " + dir.file("d3.txt"));
  EXPECT_EQ(r.exit_code, 2) << r.output;
  EXPECT_NE(r.output.find("--iterations"), std::string::npos) << r.output;
  r = run_tool("denoise --model " + run + "/model --input " + s5("walking_1.txt") + " --keep-observed --out " +
               dir.file("d3.txt"));
  EXPECT_EQ(r.exit_code, 2) << r.output;
  EXPECT_NE(r.output.find("--zeros-are-missing"), std::string::npos) << r.output;

  // A motion shorter than a clip is bad input, named in the message.
  {
    std::ofstream short_file(dir.file("short.txt"));
    for (int frame = 0; frame < 20; ++frame) {
      for (int c = 0; c < 99; ++c) short_file << (c ? ",0.0" : "0.0");
      short_file << '\n';
    }
  }
  r = run_tool("encode --model " + run + "/model --input " + dir.file("short.txt"));
  EXPECT_EQ(r.exit_code, 2) << r.output;
  EXPECT_NE(r.output.find("short.txt"), std::string::npos) << r.output;
}

TEST(Tool, VersionIsTheProjectVersion) {
  const auto r = run_tool("--version");
  EXPECT_EQ(r.exit_code, 0) << r.output;
  EXPECT_NE(r.output.find(MM_PROJECT_VERSION), std::string::npos) << r.output;
}

TEST(Tool, HelpCreditsThePapersAuthors) {
  const auto r = run_tool("--help");
  EXPECT_EQ(r.exit_code, 0) << r.output;
  EXPECT_NE(r.output.find("Jang & Lee"), std::string::npos) << r.output;
  EXPECT_EQ(r.output.find("Yoon"), std::string::npos) << r.output;
}

// --help is read on machines other than the build's: a default that is this
// build's absolute path (the shipped model's folder) is described instead.
TEST(Tool, HelpShowsNoPathOfTheBuildMachine) {
  const std::string source_dir = std::filesystem::path(MM_SHIPPED_MODEL).parent_path().parent_path().string();
  for (const std::string command :
       {"encode", "decode", "sample", "interpolate", "analogy", "denoise", "evaluate", "take encode",
        "take reconstruct", "take denoise", "take decode", "take resample", "take mirror", "take-seams", "evaluate-gaps",
        "evaluate-keyframes", "evaluate-transitions", "join-clips"}) {
    const auto r = run_tool(command + " --help");
    EXPECT_EQ(r.exit_code, 0) << command << ": " << r.output;
    // The options' part: the Usage line names the binary as it was called.
    const std::string options = r.output.substr(std::min(r.output.find("Options:"), r.output.size()));
    EXPECT_EQ(options.find(source_dir), std::string::npos) << command << ": " << r.output;
    EXPECT_NE(r.output.find("--model"), std::string::npos) << command << ": " << r.output;
  }
}

// The gap benchmark's JSON holds one record a gap, which the tables'
// means are made of, with how well the gap's fitted code met the frames
// observed around it (docs/RESULTS.md relates the two), and beside the
// border jumps the recording's own move at the same frames.
TEST(Tool, TheGapBenchmarkRecordsEveryGapWithItsFit) {
  MM_REQUIRE_H36M();
  test::ScratchDir dir;
  const auto r = run_tool_split("evaluate-gaps " + kModel + " --input " + s5("walking_1.txt") +
                                " --joints 0 --seconds 1 --fit-iterations 2 --out " + dir.file("gaps.json"));
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const auto document = nlohmann::json::parse(read_text(dir.file("gaps.json")));
  const auto& records = document.at("gap_records");
  ASSERT_EQ(records.size(), document.at("gaps").get<size_t>());
  ASSERT_GE(records.size(), 3u);
  double cubic = 0;
  for (const auto& record : records) {
    EXPECT_EQ(record.at("action"), "walking");
    EXPECT_EQ(record.at("seconds"), 1.0);
    // Every joint missing for 1 s: each gap gets a fitted window.
    EXPECT_GT(record.at("fit_observed_error").get<double>(), 0.0) << record.dump();
    cubic += record.at("cubic").at("mpjpe_mm").get<double>();
  }
  const auto& methods = document.at("configurations").at(0).at("methods");
  const double table = methods.at("cubic").at("mpjpe_mm").get<double>();
  EXPECT_NEAR(cubic / static_cast<double>(records.size()), table, 1e-9);
  // The recording's own border move, the jumps' reference, is the same
  // beside every method; the recording moves there.
  const double recorded = methods.at("slerp").at("recorded_border_jump_ratio").get<double>();
  EXPECT_GT(recorded, 0.0);
  for (const auto& [name, method] : methods.items()) {
    EXPECT_EQ(method.at("recorded_border_jump_ratio").get<double>(), recorded) << name;
  }
}

// decode writes 25 Hz; encode reads it back with --rate 25, and the code it
// finds is near the one decoded: much nearer than another walk's code.
TEST(Tool, DecodedMotionEncodesBackToANearbyCode) {
  MM_REQUIRE_H36M();
  test::ScratchDir dir;
  auto r = run_tool_split("encode " + kModel + " --input " + s5("walking_1.txt"));
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const std::string code_file = dir.write("walking_1.json", r.out);
  const auto code = code_of(r.out);
  r = run_tool_split("encode " + kModel + " --input " + s5("walking_2.txt"));
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const auto other_walk = code_of(r.out);

  r = run_tool_split("decode " + kModel + " --code " + code_file + " --out " + dir.file("decoded.txt"));
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_EQ(lines_of(read_text(dir.file("decoded.txt"))).size(), 150u);
  // The decoded motion travels in world layout: --generated brings its
  // root back to the changes the model reads. Read as recorded data, its
  // world orientation lies far from anything the model saw.
  r = run_tool_split("encode " + kModel + " --rate 25 --generated --input " + dir.file("decoded.txt"));
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const auto round_trip = code_of(r.out);
  EXPECT_EQ(nlohmann::json::parse(r.err)["rate"], 25);  // which window: on stderr, apart from the code
  EXPECT_LT(distance(code, round_trip), 0.4 * distance(code, other_walk));

  // At the default 50 Hz the decoded file holds only 75 frames: the message says what to do.
  r = run_tool_split("encode " + kModel + " --input " + dir.file("decoded.txt"));
  EXPECT_EQ(r.exit_code, 2) << r.err;
  EXPECT_NE(r.err.find("decoded.txt"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("--rate 25"), std::string::npos) << r.err;
}

// Reading a 50 Hz file keeps every second frame: the same frames written at
// 25 Hz give the very same window, hence the same code. --start counts the
// file's own frames (rows), as the service's start does: row 80 of the
// 50 Hz file is row 40 of its even frames.
TEST(Tool, A50HzFileReadsAsItsEvenFramesAt25Hz) {
  MM_REQUIRE_H36M();
  test::ScratchDir dir;
  const auto lines = lines_of(read_text(s5("walking_1.txt")));
  std::string even;
  for (size_t i = 0; i < lines.size(); i += 2) even += lines[i] + "\n";
  const std::string slow = dir.write("walking_1_25hz.txt", even);
  const auto at_50 = run_tool_split("encode " + kModel + " --start 80 --input " + s5("walking_1.txt"));
  const auto at_25 = run_tool_split("encode " + kModel + " --start 40 --rate 25 --input " + slow);
  ASSERT_EQ(at_50.exit_code, 0) << at_50.err;
  ASSERT_EQ(at_25.exit_code, 0) << at_25.err;
  EXPECT_EQ(code_of(at_50.out), code_of(at_25.out));
  const auto unshifted = run_tool_split("encode " + kModel + " --rate 25 --input " + slow);
  EXPECT_NE(code_of(unshifted.out), code_of(at_25.out)) << "--start must move the window";
}

// "-" is standard input for code and motion files and standard output for
// --out, whose message then goes to stderr so that stdout is only data.
TEST(Tool, DashReadsStandardInputAndWritesStandardOutput) {
  test::ScratchDir dir;
  auto r = run_tool_split("encode " + kModel + " --rate 25 --input " +
                          dir.write("still.txt", synthetic_motion(150)));
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const std::string code_file = dir.write("code.json", r.out);

  r = run_tool_split("decode " + kModel + " --code - --out -", code_file);
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const auto lines = lines_of(r.out);
  ASSERT_EQ(lines.size(), 150u) << r.out.substr(0, 200);
  for (const auto& line : lines) ASSERT_EQ(std::count(line.begin(), line.end(), ','), 98) << line;
  EXPECT_NE(r.err.find("wrote standard output"), std::string::npos) << r.err;
  const std::string decoded = dir.write("decoded.txt", r.out);

  const auto from_stdin = run_tool_split("encode " + kModel + " --rate 25 --input -", decoded);
  const auto from_file = run_tool_split("encode " + kModel + " --rate 25 --input " + decoded);
  ASSERT_EQ(from_stdin.exit_code, 0) << from_stdin.err;
  EXPECT_EQ(code_of(from_stdin.out), code_of(from_file.out));
  EXPECT_EQ(nlohmann::json::parse(from_stdin.err)["input"], "standard input");

  // denoise's report moves to stderr when the motion goes to stdout.
  r = run_tool_split("denoise " + kModel + " --rate 25 --input - --out -", decoded);
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_EQ(lines_of(r.out).size(), 150u);
  EXPECT_NE(r.err.find("denoised_mpjpe_mm"), std::string::npos) << r.err;

  // analogy and interpolate take - for one input and --rate per input.
  r = run_tool_split("analogy " + kModel + " --rate 25,50,25 --a - --b " + dir.write("b.txt", synthetic_motion(300)) +
                         " --c " + decoded + " --out -",
                     decoded);
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_EQ(lines_of(r.out).size(), 150u);
  r = run_tool_split("interpolate " + kModel + " --rate 25 --steps 2 --from - --to " + decoded + " --out-dir " +
                         dir.file("between"),
                     decoded);
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_TRUE(std::filesystem::exists(dir.file("between/interpolation_001.txt")));

  r = run_tool_split("analogy " + kModel + " --rate 25 --a - --b - --c " + decoded + " --out -", decoded);
  EXPECT_EQ(r.exit_code, 2) << r.err;
  EXPECT_NE(r.err.find("standard input"), std::string::npos) << r.err;
}

// A bad path must fail before the model loads: with a model folder that
// does not exist, the message is about the input, not the model.
TEST(Tool, InputPathsAreCheckedBeforeTheModelLoads) {
  test::ScratchDir dir;
  const std::string no_model = "--model " + dir.file("no-model");
  for (const std::string& command :
       {"encode --input " + dir.file("missing.txt"), "decode --code " + dir.file("missing.json") + " --out x.txt",
        "denoise --input " + dir.file("missing.txt") + " --out x.txt",
        "analogy --a " + dir.write("present.txt", "0") + " --b " + dir.file("missing.txt") + " --c - --out x.txt"}) {
    const auto r = run_tool(command + " " + no_model);
    EXPECT_EQ(r.exit_code, 2) << command << ": " << r.output;
    EXPECT_NE(r.output.find("missing."), std::string::npos) << command << ": " << r.output;
    EXPECT_EQ(r.output.find("no-model"), std::string::npos) << command << ": " << r.output;
  }
  const auto r = run_tool("decode --code " + dir.write("c.json", "[0]") + " --out " +
                          dir.file("no-folder/x.txt") + " " + no_model);
  EXPECT_EQ(r.exit_code, 2) << r.output;
  EXPECT_NE(r.output.find("no-folder"), std::string::npos) << r.output;
}

// Every bad input is exit 2 with a message naming the file, and no text of
// the libraries underneath (c10, nlohmann, std::string).
TEST(Tool, BadInputsAreExitTwoNamingTheFile) {
  test::ScratchDir dir;
  const std::string folder = dir.file("a-folder");
  std::filesystem::create_directories(folder);
  const std::string motion = dir.write("motion.txt", synthetic_motion(300));
  std::string code_values;
  for (int i = 1; i < 64; ++i) code_values += ",0.5";
  std::string huge_rotation = synthetic_motion(300);
  huge_rotation.replace(huge_rotation.find("0.1"), 3, "1e38");
  std::string huge_root = synthetic_motion(300);
  huge_root.replace(0, 3, "1e30");
  const struct {
    std::string arguments, named;
  } cases[] = {
      {"encode --input " + folder, "a-folder"},
      {"encode --input " + dir.write("rotation.txt", huge_rotation), "rotation.txt:1: value 4"},
      {"encode --input " + dir.write("root.txt", huge_root), "root.txt:1: value 1"},
      {"decode --code " + folder + " --out " + dir.file("x.txt"), "a-folder"},
      {"decode --code " + dir.write("overflow.json", "{\"code\": [1e999" + code_values + "]}") + " --out " +
           dir.file("x.txt"),
       "overflow.json"},
      {"decode --code " + dir.write("far.json", "[1e30" + code_values + "]") + " --out " + dir.file("x.txt"),
       "far.json: code[0]"},
      {"decode --code " + dir.write("string.json", "\"z\"") + " --out " + dir.file("x.txt"), "string.json"},
      {"decode --code " + dir.write("ok.json", "[0.1" + code_values + "]") + " --out " + folder, "a-folder"},
      {"analogy --a " + motion + " --b " + motion + " --c " + folder + " --out " + dir.file("x.txt"), "a-folder"},
      {"analogy --a " + motion + " --b " + motion + " --c " + motion + " --out " + folder, "a-folder"},
      {"interpolate --from " + motion + " --to " + folder + " --out-dir " + dir.file("i"), "a-folder"},
      {"interpolate --from " + motion + " --to " + motion + " --out-dir " + motion, "motion.txt"},
      {"denoise --input " + folder + " --out " + dir.file("x.txt"), "a-folder"},
      {"denoise --input " + motion + " --out " + folder, "a-folder"},
      {"sample --out-dir " + motion, "motion.txt"},
      {"render --input " + folder + " --out " + dir.file("x.svg"), "a-folder"},
      {"render --input " + motion + " --rate 50 --out " + folder, "a-folder"},
      {"plot-log --log " + folder + " --out " + dir.file("x.svg"), "a-folder"},
      {"train --config " + folder + " --dataset " + motion + " --out " + dir.file("run"), "a-folder"},
      {"train --config " + dir.write("overflow-config.json", "{\"learning_rate\": 1e999}") + " --dataset " + motion +
           " --out " + dir.file("run"),
       "overflow-config.json"},
      {"train --config " + dir.write("big-config.json", "{\"model\": {\"hidden\": 99999999999}}") + " --dataset " +
           motion + " --out " + dir.file("run"),
       "big-config.json: model.hidden"},
      {"train --dataset " + folder + " --out " + dir.file("run"), "a-folder"},
      {"resume " + folder + " --dataset " + motion, "a-folder"},
      {"evaluate --dataset " + folder, "a-folder"},
      {"evaluate --dataset " + motion + " --out " + folder, "a-folder"},
      {"bench --dataset " + folder, "a-folder"},
      {"bench --out " + folder, "a-folder"},
      {"prepare --data " + folder + " --out " + folder, "a-folder"},
  };
  for (const auto& c : cases) {
    const std::string command = c.arguments.substr(0, c.arguments.find(' '));
    const bool takes_model = command != "render" && command != "plot-log" && command != "train" &&
                             command != "resume" && command != "bench" && command != "prepare";
    const auto r = run_tool(c.arguments + (takes_model ? " " + kModel : ""));
    EXPECT_EQ(r.exit_code, 2) << c.arguments << "\n" << r.output;
    EXPECT_NE(r.output.find(c.named), std::string::npos) << c.arguments << "\n" << r.output;
    for (const char* internal : {"json.exception", "c10", "basic_string", "what()"}) {
      EXPECT_EQ(r.output.find(internal), std::string::npos) << c.arguments << "\n" << r.output;
    }
  }
}

// Files that editors start with a byte-order mark read like any other.
TEST(Tool, ByteOrderMarksAreAccepted) {
  test::ScratchDir dir;
  const std::string plain = dir.write("plain.txt", synthetic_motion(150));
  const std::string marked = dir.write("marked.txt", "\xEF\xBB\xBF" + synthetic_motion(150));
  const auto a = run_tool_split("encode " + kModel + " --rate 25 --input " + plain);
  const auto b = run_tool_split("encode " + kModel + " --rate 25 --input " + marked);
  ASSERT_EQ(b.exit_code, 0) << b.err;
  EXPECT_EQ(code_of(a.out), code_of(b.out));
  const auto decoded = run_tool_split("decode " + kModel + " --code " + dir.write("code.json", "\xEF\xBB\xBF" + b.out) +
                                      " --out " + dir.file("d.txt"));
  EXPECT_EQ(decoded.exit_code, 0) << decoded.err;
  const auto config = run_tool("train --config " + dir.write("config.json", "\xEF\xBB\xBF{\"batch\": 4}") +
                               " --dataset " + dir.file("missing.mmd") + " --out " + dir.file("run"));
  EXPECT_EQ(config.exit_code, 2) << config.output;
  EXPECT_NE(config.output.find("missing.mmd"), std::string::npos) << "the configuration must parse: " << config.output;
}

TEST(Tool, DecodingBeyondTheMemoryLimitNamesTheMemory) {
  test::ScratchDir dir;
  const auto r = run_tool("sample " + kModel + " --count 100000 --out-dir " + dir.file("samples"));
  EXPECT_EQ(r.exit_code, 2) << r.output;
  for (const char* said : {"--count 100000", "GB", "1 GiB", "at most"}) {
    EXPECT_NE(r.output.find(said), std::string::npos) << said << ": " << r.output;
  }
  EXPECT_FALSE(std::filesystem::exists(dir.file("samples/sample_000.txt")));
  const std::string motion = dir.write("motion.txt", synthetic_motion(300));
  const auto steps = run_tool("interpolate " + kModel + " --steps 100000 --from " + motion + " --to " + motion +
                              " --out-dir " + dir.file("between"));
  EXPECT_EQ(steps.exit_code, 2) << steps.output;
  EXPECT_NE(steps.output.find("--steps 100000"), std::string::npos) << steps.output;
  const auto within = run_tool("sample " + kModel + " --count 2 --out-dir " + dir.file("samples"));
  EXPECT_EQ(within.exit_code, 0) << within.output;
  EXPECT_TRUE(std::filesystem::exists(dir.file("samples/sample_001.txt")));
}

TEST(Tool, ResumeWithoutADatasetIsAUsageError) {
  const auto r = run_tool("train --resume /tmp/nothing/checkpoint.pt");
  EXPECT_EQ(r.exit_code, 2) << r.output;
}

}  // namespace
}  // namespace mm

namespace mm {
namespace {

// decode writes BVH for a .bvh path; encode reads it back (by its name, or
// by its HIERARCHY from standard input) to the code of the same motion as
// text, up to the Euler conversion's rounding.
TEST(ToolBvh, DecodedBvhEncodesLikeTheSameMotionAsText) {
  test::ScratchDir dir;
  auto r = run_tool_split("encode " + kModel + " --rate 25 --input " + dir.write("still.txt", synthetic_motion(150)));
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const std::string code_file = dir.write("code.json", r.out);
  r = run_tool_split("decode " + kModel + " --code " + code_file + " --out " + dir.file("decoded.txt"));
  ASSERT_EQ(r.exit_code, 0) << r.err;
  r = run_tool_split("decode " + kModel + " --code " + code_file + " --out " + dir.file("decoded.bvh"));
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const std::string bvh = read_text(dir.file("decoded.bvh"));
  EXPECT_EQ(bvh.rfind("HIERARCHY\nROOT Hips\n", 0), 0u) << bvh.substr(0, 100);
  EXPECT_NE(bvh.find("Frames: 150\nFrame Time: 0.04\n"), std::string::npos);

  const auto text_code = run_tool_split("encode " + kModel + " --rate 25 --generated --input " + dir.file("decoded.txt"));
  const auto bvh_code = run_tool_split("encode " + kModel + " --generated --input " + dir.file("decoded.bvh"));
  const auto stdin_code = run_tool_split("encode " + kModel + " --generated --input -", dir.file("decoded.bvh"));
  ASSERT_EQ(text_code.exit_code, 0) << text_code.err;
  ASSERT_EQ(bvh_code.exit_code, 0) << bvh_code.err;
  ASSERT_EQ(stdin_code.exit_code, 0) << stdin_code.err;
  EXPECT_LT(distance(code_of(text_code.out), code_of(bvh_code.out)), 1e-3);
  EXPECT_EQ(code_of(bvh_code.out), code_of(stdin_code.out));
}

TEST(ToolBvh, DenoiseAnalogySampleAndInterpolateWriteBvh) {
  test::ScratchDir dir;
  const std::string still = dir.write("still.txt", synthetic_motion(150));
  auto r = run_tool_split("denoise " + kModel + " --rate 25 --input " + still + " --out " + dir.file("d.bvh"));
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_EQ(read_text(dir.file("d.bvh")).rfind("HIERARCHY", 0), 0u);
  // The BVH written feeds the next command.
  r = run_tool_split("analogy " + kModel + " --a " + dir.file("d.bvh") + " --b " + still + " --c " + still +
                     " --rate 25 --out " + dir.file("a.bvh"));
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(read_text(dir.file("a.bvh")).find("Frames: 150"), std::string::npos);
  r = run_tool_split("sample " + kModel + " --count 2 --format bvh --out-dir " + dir.file("samples"));
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_TRUE(std::filesystem::exists(dir.file("samples/sample_001.bvh")));
  r = run_tool_split("interpolate " + kModel + " --rate 25 --steps 2 --from " + dir.file("d.bvh") + " --to " + still +
                     " --format bvh --out-dir " + dir.file("path"));
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_EQ(read_text(dir.file("path/interpolation_000.bvh")).rfind("HIERARCHY", 0), 0u);
}

TEST(ToolBvh, AnotherSkeletonOrABrokenBvhIsExitTwoNamingTheFile) {
  test::ScratchDir dir;
  const std::string other = dir.write(
      "other.bvh",
      "HIERARCHY\nROOT hip\n{\n OFFSET 0 0 0\n CHANNELS 3 Zrotation Yrotation Xrotation\n End Site\n {\n  OFFSET 0 1 0\n }\n}\n"
      "MOTION\nFrames: 1\nFrame Time: 0.04\n0 0 0\n");
  auto r = run_tool_split("encode " + kModel + " --input " + other);
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.err.find("other.bvh: not the H3.6M skeleton"), std::string::npos) << r.err;
  const std::string broken = dir.write("broken.bvh", "HIERARCHY\nROOT hip\n{\n OFFSET 0 0 nan\n");
  r = run_tool_split("encode " + kModel + " --input " + broken);
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.err.find("broken.bvh:4:"), std::string::npos) << r.err;
}

}  // namespace
}  // namespace mm
