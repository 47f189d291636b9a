// InputError: the one exception type for malformed user input (files,
// JSON documents, request fields, command-line options) across the project.
//
// A distinct type lets callers (the server, the command-line tools) map bad
// input to a client error and everything else to an internal error without
// parsing messages. The message is written for a person: it names the file or
// field, the line where there is one, the offending value, and what was
// expected, e.g. "walking_1.txt:17: expected 99 values, found 98".
#pragma once

#include <stdexcept>
#include <string>

namespace mm {

// Thrown for malformed input. Safe to copy and to throw across threads (e.g.
// rethrown from a worker via std::exception_ptr).
class InputError : public std::runtime_error {
 public:
  // Input named in the message itself (a file and its line).
  explicit InputError(const std::string& message) : std::runtime_error(message), detail_(message) {}
  // A named field or option ("hop_seconds", "windows[2].code",
  // "motions[0].columns", "--gap-fill"): what() is "<field>: <detail>", and
  // field() and detail() give the two apart, so that the service answers
  // with the field beside the message. An empty field is the whole input
  // (a request body): what() is then the detail alone.
  InputError(std::string field, std::string detail)
      : std::runtime_error(field.empty() ? detail : field + ": " + detail),
        field_(std::move(field)),
        detail_(std::move(detail)) {}

  // The field named, or empty.
  const std::string& field() const { return field_; }
  // The message without the field.
  const std::string& detail() const { return detail_; }

 private:
  std::string field_;
  std::string detail_;
};

}  // namespace mm
