// The motion-manifold command-line tool end to end, as a user runs it: real
// H3.6M files, a real prepared dataset, a short real training run, and the
// exit codes and messages of bad input.
#include <gtest/gtest.h>
#include <sys/wait.h>

#include <array>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <map>
#include <nlohmann/json.hpp>
#include <string>

#include "test_environment.h"

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

TEST(Tool, UnknownVariantIsAUsageErrorNamingTheValue) {
  const auto r = run_tool("train --variant XYZ --dataset nowhere.mmd --out /tmp/unused");
  EXPECT_EQ(r.exit_code, 2) << r.output;
  EXPECT_NE(r.output.find("XYZ"), std::string::npos) << r.output;
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
  ASSERT_EQ(results.size(), 6u);
  std::map<std::string, int64_t> operations;
  for (const auto& result : results) {
    EXPECT_GT(result["median_ms"].get<double>(), 0.0) << result.dump();
    EXPECT_GT(result["operations"].get<int64_t>(), 0) << result.dump();
    operations[result["operation"].get<std::string>() + " " + std::to_string(result["batch"].get<int>())] =
        result["operations"].get<int64_t>();
  }
  EXPECT_GT(operations.at("training iteration (DKGM) 4"), 2 * operations.at("decode (rotation) 1"));
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
               " --corrupt-probability 0.5 --zeros-are-missing --iterations 2 --keep-observed --out " +
               dir.file("d2.txt"));
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_NE(r.output.find("\"zeros_are_missing\": true"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("\"keep_observed\": true"), std::string::npos) << r.output;
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

TEST(Tool, ResumeWithoutADatasetIsAUsageError) {
  const auto r = run_tool("train --resume /tmp/nothing/checkpoint.pt");
  EXPECT_EQ(r.exit_code, 2) << r.output;
}

}  // namespace
}  // namespace mm
