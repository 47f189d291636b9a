// Argument checks shared by the subcommands, with messages that read well
// ("--count: expected an integer >= 1, found 0"); CLI11's PositiveNumber
// prints the range up to DBL_MAX instead.
#pragma once

#include <CLI/CLI.hpp>
#include <string>

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

}  // namespace mm::tool
