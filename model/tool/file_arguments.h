// The files named on the command line: "-" stands for standard input (an
// input) or standard output (an output that is one file), and every path is
// checked before a command starts its work, so that a typo fails at once
// with exit 2 instead of after the model has loaded. Torch-free.
#pragma once

#include <cstdio>
#include <initializer_list>
#include <string>
#include <utility>
#include <vector>

namespace mm::tool {

// The path that stands for standard input or output.
inline constexpr const char* kStandardStream = "-";

bool is_standard_stream(const std::string& path);

// How messages name a path: "standard input" for "-", else the path.
std::string input_name(const std::string& path);

// Checks that the input file `path` given to `option` exists, is no
// directory and can be opened for reading, for inputs that a library reads
// by path. Throws InputError naming the option and the path.
void check_input_file(const std::string& path, const std::string& option);

// The whole of the input file `path` given to `option` ("--input"), or of
// standard input for "-". Pipes and other non-regular files (e.g. a shell's
// <(...)) are read to their end. Throws InputError naming the option and
// the path when the file does not exist, is a directory or cannot be read.
std::string read_input_file(const std::string& path, const std::string& option);

// Throws InputError naming the option when more than one of `paths` is "-":
// standard input can be read only once.
// `option_paths` holds (option, path) pairs.
void check_one_standard_input(const std::vector<std::pair<std::string, std::string>>& option_paths);

// The reason in a JSON library error's message, without the library's
// "[json.exception.out_of_range.406] " prefix, for messages to a person.
std::string json_error_reason(const std::string& what);

// Checks an output file given to `option` before any work: the path must
// not be a directory and its folder must exist. "-" (standard output) is
// fine unless `why_no_standard_output` says why this output cannot go there
// (a binary file, or standard output already carries other results). Throws
// InputError naming the option, the path and what is wrong.
void check_output_file(const std::string& path, const std::string& option,
                       const char* why_no_standard_output = nullptr);

// Writes `bytes` to standard output for "-" (flushed), otherwise atomically
// to the file (see write_file_atomically). Throws InputError for a path that
// cannot be created, std::runtime_error when writing fails.
void write_output_file(const std::string& path, const std::string& bytes);

// Where a command's messages go: stderr when one of its outputs is standard
// output (which then carries only data), stdout otherwise.
std::FILE* message_stream(std::initializer_list<std::string> output_paths);

}  // namespace mm::tool
