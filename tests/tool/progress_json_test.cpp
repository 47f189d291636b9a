// train/resume --progress-json: one JSON line per progress report on stdout,
// the interface the service's training jobs read; stderr keeps its progress
// line.
#include <gtest/gtest.h>
#include <sys/wait.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <set>
#include <sstream>
#include <string>
#include <vector>

#include "tests/common/test_environment.h"

namespace mm {
namespace {

namespace fs = std::filesystem;

std::string read_file(const fs::path& path) {
  std::ifstream in(path, std::ios::binary);
  std::stringstream text;
  text << in.rdbuf();
  return text.str();
}

struct Streams {
  int exit_code;
  std::string out, err;
};

Streams run(const test::ScratchDir& dir, const std::string& arguments) {
  const std::string command = std::string(MM_TOOL_PATH) + " " + arguments + " >" + dir.file("out") + " 2>" +
                              dir.file("err") + " </dev/null";
  const int status = std::system(command.c_str());
  return {WIFEXITED(status) ? WEXITSTATUS(status) : -1, read_file(dir.file("out")), read_file(dir.file("err"))};
}

std::vector<nlohmann::json> json_lines(const std::string& text) {
  std::vector<nlohmann::json> lines;
  std::istringstream in(text);
  for (std::string line; std::getline(in, line);) {
    auto parsed = nlohmann::json::parse(line, nullptr, false);
    EXPECT_FALSE(parsed.is_discarded()) << "not a JSON line: " << line;
    lines.push_back(parsed);
  }
  return lines;
}

TEST(Tool, ProgressJsonPrintsEachReportAsOneJsonLineOnStdout) {
  MM_REQUIRE_H36M();
  test::ScratchDir dir;
  const std::string dataset = dir.file("small.mmd");
  for (const auto& [subject, file] : {std::pair{"S1", "posing_2.txt"}, std::pair{"S5", "greeting_1.txt"}}) {
    fs::create_directories(dir.path() / "tree" / subject);
    fs::create_symlink(test::h36m_dataset_dir() / subject / file, dir.path() / "tree" / subject / file);
  }
  ASSERT_EQ(run(dir, "prepare --data " + dir.file("tree") + " --train S1 --test S5 --out " + dataset).exit_code, 0);

  const std::string run_dir = dir.file("run");
  auto r = run(dir, "train --variant D --hidden 16 --batch 4 --iterations 20 --seed 1 --dataset " + dataset +
                        " --out " + run_dir + " --progress-json");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const auto lines = json_lines(r.out);
  ASSERT_EQ(lines.size(), 2u) << r.out;  // log_every 10: iterations 10 and 20
  // Every loss term the run logs, by the log's own names.
  std::istringstream log(read_file(run_dir + "/train_log.csv"));
  std::string header;
  std::getline(log, header);
  std::set<std::string> terms;
  std::istringstream columns(header);
  for (std::string column; std::getline(columns, column, ',');) {
    if (column != "iteration" && column != "learning_rate") terms.insert(column);
  }
  for (size_t i = 0; i < lines.size(); ++i) {
    const auto& line = lines[i];
    EXPECT_EQ(line.at("iteration").get<int>(), 10 * static_cast<int>(i + 1));
    EXPECT_EQ(line.at("total").get<int>(), 20);
    EXPECT_GT(line.at("iterations_per_second").get<double>(), 0);
    EXPECT_GE(line.at("eta_seconds").get<double>(), 0);
    std::set<std::string> reported;
    for (const auto& [name, value] : line.at("losses").items()) {
      reported.insert(name);
      EXPECT_TRUE(value.is_number()) << name;
    }
    EXPECT_EQ(reported, terms);
  }
  EXPECT_EQ(lines.back().at("eta_seconds").get<double>(), 0);
  EXPECT_NE(r.err.find("20/20"), std::string::npos) << "stderr keeps its progress line: " << r.err;

  // resume takes the flag too; without it stdout stays empty.
  r = run(dir, "resume " + run_dir + "/checkpoint.pt --dataset " + dataset + " --iterations 30 --progress-json");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const auto resumed = json_lines(r.out);
  ASSERT_EQ(resumed.size(), 1u) << r.out;
  EXPECT_EQ(resumed[0].at("iteration").get<int>(), 30);
  r = run(dir, "train --resume " + run_dir + "/checkpoint.pt --dataset " + dataset + " --iterations 40");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_EQ(r.out, "");
}

}  // namespace
}  // namespace mm
