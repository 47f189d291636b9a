// Argument checks shared by the subcommands, with messages that read well
// ("--count: expected an integer >= 1, found 0"); CLI11's PositiveNumber
// prints the range up to DBL_MAX instead.
#pragma once

#include <CLI/CLI.hpp>
#include <string>
#include <vector>

#include "format/input_error.h"

namespace mm::tool {

inline CLI::Validator at_least(long long minimum) {
  return CLI::Validator(
      [minimum](std::string& value) -> std::string {
        try {
          size_t used = 0;
          if (std::stoll(value, &used) >= minimum && used == value.size()) return "";
        } catch (const std::exception&) {
        }
        return "expected an integer >= " + std::to_string(minimum) + ", found " + value;
      },
      "INT>=" + std::to_string(minimum));
}

// A number above 0, or "inf" (no bound).
inline CLI::Validator positive_or_inf() {
  return CLI::Validator(
      [](std::string& value) -> std::string {
        try {
          size_t used = 0;
          if (std::stod(value, &used) > 0 && used == value.size()) return "";
        } catch (const std::exception&) {
        }
        return "expected a number above 0 or inf, found " + value;
      },
      "NUMBER>0|inf");
}

// An option that takes one value for every input or one per input (in the
// order the inputs are listed): the value for input `input` of `inputs`, or
// `fallback` when the option was not given. Throws InputError naming the
// option when the count is neither.
template <typename T>
T per_input(const std::vector<T>& values, size_t input, T fallback, const char* option, size_t inputs) {
  if (values.empty()) return fallback;
  if (values.size() != 1 && values.size() != inputs) {
    throw InputError(std::string(option), "expected one value or one per input (" + std::to_string(inputs) +
                     "), found " + std::to_string(values.size()));
  }
  return values.size() == 1 ? values[0] : values[input];
}

// --rate of every command that reads motions: 25 or 50 Hz, one for all
// inputs or one per input, comma-separated. `inputs` names them in order.
inline CLI::Option* add_rate_option(CLI::App* command, std::vector<int>& rates, int default_rate,
                                    const std::string& inputs) {
  return command
      ->add_option("--rate", rates,
                   "frame rate of " + inputs + ": 50 (data set files) or 25 (files this tool wrote); default " +
                       std::to_string(default_rate))
      ->check(CLI::IsMember({25, 50}))
      ->delimiter(',');
}

}  // namespace mm::tool
