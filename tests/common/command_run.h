// Runs one of the project's binaries as a user does, through the shell, and
// keeps what it wrote on each stream: the shared runner of the suites that
// test a command-line program (the tool, the client).
#pragma once

#include <sys/wait.h>

#include <cstdlib>
#include <fstream>
#include <sstream>
#include <string>

#include "tests/common/test_environment.h"

namespace mm::test {

// A whole file as bytes; empty when it cannot be read.
inline std::string read_text(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  std::stringstream text;
  text << in.rdbuf();
  return text.str();
}

struct CommandRun {
  int exit_code;  // -1 when the program did not exit by itself
  std::string out, err;
};

// `binary arguments` (`arguments` as shell words), stdout and stderr apart;
// `input` (a file) becomes its standard input when given, /dev/null otherwise.
inline CommandRun run_command(const std::string& binary, const std::string& arguments,
                              const std::string& input = "") {
  ScratchDir streams;
  const std::string command = binary + " " + arguments + " >" + streams.file("out") + " 2>" + streams.file("err") +
                              (input.empty() ? " </dev/null" : " <" + input);
  const int status = std::system(command.c_str());
  return {WIFEXITED(status) ? WEXITSTATUS(status) : -1, read_text(streams.file("out")), read_text(streams.file("err"))};
}

}  // namespace mm::test
