// What the client suites share: the client run as a user runs it, the S5
// files of the H3.6M copy, and motion text read back as rows of values.
#pragma once

#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include "tests/common/command_run.h"
#include "tests/common/test_environment.h"

namespace mm::test {

// Runs the client with `arguments` (shell words), stdout and stderr apart.
inline CommandRun run_client(const std::string& arguments) { return run_command(MM_CLIENT_PATH, arguments); }

inline std::string s5(const std::string& name) { return (h36m_dataset_dir() / "S5" / name).string(); }

// Lines of a motion text file, each split into its values.
inline std::vector<std::vector<double>> motion_rows(const std::string& path) {
  std::vector<std::vector<double>> rows;
  std::ifstream in(path);
  for (std::string line; std::getline(in, line);) {
    if (line.empty()) continue;
    std::vector<double> row;
    std::stringstream values(line);
    for (std::string v; std::getline(values, v, ',');) row.push_back(std::stod(v));
    rows.push_back(row);
  }
  return rows;
}

}  // namespace mm::test
