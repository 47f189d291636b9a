#include "model/tool/file_arguments.h"

#include <cerrno>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <iterator>
#include <system_error>

#include "format/atomic_file.h"
#include "format/input_error.h"

namespace mm::tool {

namespace fs = std::filesystem;

bool is_standard_stream(const std::string& path) { return path == kStandardStream; }

std::string input_name(const std::string& path) { return is_standard_stream(path) ? "standard input" : path; }

namespace {

// The file's status, after refusing a missing path and a directory.
fs::file_status existing_file_status(const std::string& path, const std::string& option) {
  std::error_code error;
  const fs::file_status status = fs::status(path, error);
  if (!fs::exists(status)) {
    throw InputError(option + " " + path + ": no such file" + (path.empty() ? " (the path is empty)" : ""));
  }
  if (fs::is_directory(status)) throw InputError(option + " " + path + ": is a directory, expected a file");
  return status;
}

}  // namespace

void check_input_file(const std::string& path, const std::string& option) {
  existing_file_status(path, option);
  std::ifstream in(path, std::ios::binary);
  if (!in) throw InputError(option + " " + path + ": cannot open file for reading: " + std::strerror(errno));
}

std::string read_input_file(const std::string& path, const std::string& option) {
  if (is_standard_stream(path)) {
    std::string bytes((std::istreambuf_iterator<char>(std::cin)), std::istreambuf_iterator<char>());
    if (std::cin.bad()) throw InputError(option + " -: reading standard input failed");
    return bytes;
  }
  const fs::file_status status = existing_file_status(path, option);
  if (fs::is_regular_file(status)) {
    try {
      return read_whole_file(path);
    } catch (const InputError& e) {
      throw InputError(option + " " + e.what());
    }
  }
  // A pipe or device: no size to ask for, so read to the end.
  std::ifstream in(path, std::ios::binary);
  if (!in) throw InputError(option + " " + path + ": cannot open file for reading: " + std::strerror(errno));
  std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  if (in.bad()) throw InputError(option + " " + path + ": read failed");
  return bytes;
}

void check_one_standard_input(const std::vector<std::pair<std::string, std::string>>& option_paths) {
  std::string first;
  for (const auto& [option, path] : option_paths) {
    if (!is_standard_stream(path)) continue;
    if (first == option) throw InputError(option, "- (standard input) given twice; it can be read only once");
    if (!first.empty()) {
      throw InputError(first + " and " + option + " are both - (standard input), which can be read only once");
    }
    first = option;
  }
}

std::string json_error_reason(const std::string& what) {
  const size_t end = what.find("] ");
  return what.rfind("[json.exception.", 0) == 0 && end != std::string::npos ? what.substr(end + 2) : what;
}

void check_output_file(const std::string& path, const std::string& option, const char* why_no_standard_output) {
  if (is_standard_stream(path)) {
    if (why_no_standard_output == nullptr) return;
    throw InputError(option + " -: cannot write to standard output: " + why_no_standard_output +
                     "; expected a file path");
  }
  if (path.empty()) throw InputError(option, "the path is empty, expected a file path or - (standard output)");
  std::error_code error;
  if (fs::is_directory(path, error)) {
    throw InputError(option + " " + path + ": is a directory, expected a file path" +
                     (why_no_standard_output == nullptr ? " (or - for standard output)" : ""));
  }
  const fs::path folder = fs::path(path).parent_path();
  if (!folder.empty() && !fs::is_directory(folder, error)) {
    throw InputError(option + " " + path + ": the folder " + folder.string() + " does not exist");
  }
}

void write_output_file(const std::string& path, const std::string& bytes) {
  if (!is_standard_stream(path)) {
    write_file_atomically(path, bytes);
    return;
  }
  if (std::fwrite(bytes.data(), 1, bytes.size(), stdout) != bytes.size() || std::fflush(stdout) != 0) {
    throw std::runtime_error(std::string("writing to standard output failed: ") + std::strerror(errno));
  }
}

std::FILE* message_stream(std::initializer_list<std::string> output_paths) {
  for (const auto& path : output_paths) {
    if (is_standard_stream(path)) return stderr;
  }
  return stdout;
}

}  // namespace mm::tool
