// InputError: the one exception type for malformed user input (files,
// JSON documents, request fields) across the format library.
//
// A distinct type lets callers (the server, the command-line tools) map bad
// input to a client error and everything else to an internal error without
// parsing messages. The message is written for a person: it names the file or
// field, the line where there is one, the offending value, and what was
// expected, e.g. "walking_1.txt:17: expected 99 values, found 98".
#pragma once

#include <stdexcept>

namespace mm {

// Thrown for malformed input. Carries only its message; safe to copy and to
// throw across threads (e.g. rethrown from a worker via std::exception_ptr).
class InputError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

}  // namespace mm
